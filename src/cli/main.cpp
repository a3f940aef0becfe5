// fskin: the command-line front end. Every subcommand is a thin layer over
// the library; see `fskin --help`.
#include <ATen/Context.h>
#include <ATen/Parallel.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <thread>

#include "cli/commands.h"
#include "fskin/core/error.h"
#include "fskin/util/blas_threads.h"
#include "fskin/util/free_cores.h"
#include "fskin/util/runtime_restart.h"
#include "fskin/version.h"

int main(int argc, char** argv) {
  // May restart the process with faster OpenBLAS kernels and a short OpenMP
  // spin-wait (runtime_restart.h); first, so nothing is done twice.
  fskin::restart_with_runtime_settings(argv, fskin::is_long_running_command(argc, argv));
  CLI::App app{"fskin: differentiable forward skinning (SNARF, Fast-SNARF, INS)", "fskin"};
  app.set_version_flag("--version", std::string("fskin ") + FSKIN_VERSION);
  app.require_subcommand(1);
  const int cores = std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  int threads = cores;
  auto* threads_option =
      app.add_option("--threads", threads,
                     "CPU threads for LibTorch and fskin kernels, fixed (default: one per core, fewer while other "
                     "processes keep cores busy)")
          ->check(CLI::PositiveNumber);
  fskin::cli::register_animate(app);
  fskin::cli::register_avatar(app);
  fskin::cli::register_bench(app);
  fskin::cli::register_character(app);
  fskin::cli::register_config(app);
  fskin::cli::register_export(app);
  fskin::cli::register_import(app);
  fskin::cli::register_pose(app);
  fskin::cli::register_poses(app);
  fskin::cli::register_data(app);
  fskin::cli::register_train(app);
  fskin::cli::register_eval(app);
  fskin::cli::register_mesh(app);
  fskin::cli::register_render(app);
  fskin::cli::register_report(app);
  // Subcommand callbacks run inside parse(), after the global options are read.
  app.parse_complete_callback([&] {
    if (threads_option->count() > 0) at::set_num_threads(threads);
    else fskin::follow_free_cores_up_to(cores);
  });
  // Saturated softmax / Softplus(100) layers produce subnormal floats, which
  // x86 processes up to 100x slower; they carry no useful signal here.
  at::globalContext().setFlushDenormal(true);
  fskin::use_single_threaded_blas();
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const fskin::Error& e) {
    std::fprintf(stderr, "fskin: error: %s\n", e.what());
    return 1;
  } catch (const std::filesystem::filesystem_error& e) {
    // A path the environment refuses (permissions, a full disk, a file in
    // the way): the user's to fix, named, not an internal error.
    std::fprintf(stderr, "fskin: error: %s: %s\n", e.path1().c_str(), e.code().message().c_str());
    return 1;
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "fskin: error: out of memory (the input asks for more than this machine has)\n");
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fskin: internal error: %s\n", e.what());
    return 2;
  }
  return 0;
}
