#pragma once
// Each subcommand lives in its own file and registers itself on the app.
#include <CLI/CLI.hpp>

namespace fskin::cli {

void register_animate(CLI::App& app);
void register_avatar(CLI::App& app);
void register_bench(CLI::App& app);
void register_character(CLI::App& app);
void register_config(CLI::App& app);
void register_export(CLI::App& app);
void register_import(CLI::App& app);
void register_pose(CLI::App& app);
void register_poses(CLI::App& app);
void register_data(CLI::App& app);
void register_train(CLI::App& app);
void register_eval(CLI::App& app);
void register_mesh(CLI::App& app);
void register_render(CLI::App& app);
void register_report(CLI::App& app);

}  // namespace fskin::cli
