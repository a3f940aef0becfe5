// fskin bench deform: times the correspondence search on the built-in
// character (Fast-SNARF CPU / CUDA and SNARF-MLP) and prints points/s, valid
// candidates, iterations and the precompute / search / filter split.
#include <torch/torch.h>

#include <ctime>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>

#include "cli/commands.h"
#include "fskin/body/character.h"
#include "fskin/core/device.h"
#include "fskin/core/error.h"
#include "fskin/util/stopwatch.h"
#include "fskin/benchmarking/character_scene.h"
#include "fskin/deformers/fast_snarf_deformer.h"
#include "fskin/deformers/snarf_deformer.h"

namespace fskin::cli {

namespace {

struct BenchOptions {
  int64_t points = 200000;
  int64_t snarf_points = 5000;
  int snarf_fit_steps = 100;
  std::string starts = "9";
  int64_t auto_count = 4;
  std::string pose = "both";
  std::string deformer = "fast_snarf";
  std::string device = "cpu";
  int repeat = 3;
  int resolution = 110;
};

StartBones parse_starts(const std::string& spec, int64_t auto_count, const Skeleton& skeleton) {
  if (spec == "all") return StartBones::all();
  if (spec == "auto") return StartBones::automatic(auto_count);
  if (spec == "9") return StartBones::by_name(skeleton, StartBones::smpl_training_names());
  fail("--starts {}: expected 9 (the papers' SMPL list), all or auto", spec);
}

// CPU time of all threads of this process: on a shared machine it shows what
// the run would take alone (cpu / threads) when the wall time is inflated.
double process_cpu_seconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

void print_row(const char* name, const char* pose, const DeformerStats& s, double seconds, double cpu_seconds) {
  std::printf("%-16s %-8s %9lld %12.0f %9.2f %9.2f %10.1f %9.1f %9.1f %9.1f %9.1f\n", name, pose,
              static_cast<long long>(s.points), static_cast<double>(s.points) / seconds, s.mean_valid,
              s.mean_iterations, 1e3 * seconds, 1e3 * s.precompute_seconds, 1e3 * s.search_seconds,
              1e3 * s.filter_seconds, 1e3 * cpu_seconds);
}

// Best of `repeat` runs (the first one also warms caches and thread pools).
void run(const char* name, const char* pose, Deformer& deformer, const torch::Tensor& x, const torch::Tensor& bones,
         int repeat) {
  torch::NoGradGuard no_grad;
  DeformerStats best;
  double best_seconds = 1e30, best_cpu = 1e30;
  for (int r = 0; r < std::max(1, repeat); ++r) {
    const double cpu_start = process_cpu_seconds();
    const auto out = deformer.forward(x, bones);
    best_cpu = std::min(best_cpu, process_cpu_seconds() - cpu_start);
    const auto& s = out.stats;
    const double total = s.precompute_seconds + s.search_seconds + s.filter_seconds;
    if (total < best_seconds) {
      best_seconds = total;
      best = s;
    }
  }
  print_row(name, pose, best, best_seconds, best_cpu);
}

}  // namespace

void register_bench(CLI::App& app) {
  auto opt = std::make_shared<BenchOptions>();
  auto* bench = app.add_subcommand("bench", "Benchmarks");
  bench->require_subcommand(1);
  auto* cmd = bench->add_subcommand("deform", "Time the correspondence search on the built-in character");
  cmd->add_option("--points", opt->points, "posed query points (Fast-SNARF)")->check(CLI::PositiveNumber);
  cmd->add_option("--snarf-points", opt->snarf_points, "posed query points for SNARF-MLP (slow)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--snarf-fit-steps", opt->snarf_fit_steps, "Adam steps fitting SNARF's MLP to the preset weights");
  cmd->add_option("--starts", opt->starts, "start bones: 9 (papers' SMPL list), all, auto");
  cmd->add_option("--auto-count", opt->auto_count, "starts kept per point with --starts auto")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--pose", opt->pose, "natural, extreme or both")->check(CLI::IsMember({"natural", "extreme", "both"}));
  cmd->add_option("--deformer", opt->deformer, "fast_snarf, snarf or both")
      ->check(CLI::IsMember({"fast_snarf", "snarf", "both"}));
  cmd->add_option("--device", opt->device, "cpu, cuda or cuda:N")->capture_default_str();
  cmd->add_option("--repeat", opt->repeat, "runs per case (the best is printed)")->check(CLI::PositiveNumber);
  cmd->add_option("--resolution", opt->resolution, "character mesh resolution")->check(CLI::PositiveNumber);
  cmd->callback([opt] {
    const torch::Device device = parse_device(opt->device);
    set_cuda_timing(true);  // stage times include their kernels
    CharacterOptions character;
    character.resolution = opt->resolution;
    const auto model = make_character_model(character);
    const char* spin = std::getenv("GOMP_SPINCOUNT");
    const char* policy = std::getenv("OMP_WAIT_POLICY");
    std::printf("threads %d, device %s, starts %s, OpenMP wait: GOMP_SPINCOUNT=%s OMP_WAIT_POLICY=%s\n",
                at::get_num_threads(), opt->device.c_str(), opt->starts.c_str(), spin ? spin : "(unset)",
                policy ? policy : "(unset)");
    std::printf("%-16s %-8s %9s %12s %9s %9s %10s %9s %9s %9s %9s\n", "deformer", "pose", "points", "points/s",
                "valid/pt", "iters", "total ms", "pre ms", "search ms", "filter ms", "cpu ms");
    for (const auto pose : {ScenePose::Natural, ScenePose::Extreme}) {
      const char* pose_name = pose == ScenePose::Natural ? "natural" : "extreme";
      if (opt->pose != "both" && opt->pose != pose_name) continue;
      const auto scene = make_character_scene(model, pose);
      const auto starts = parse_starts(opt->starts, opt->auto_count, scene.skeleton);
      const auto bones = scene.bones.to(device);
      if (opt->deformer != "snarf") {
        auto options = DeformerOptions::fast_snarf();
        options.start_bones = starts;
        auto field = scene.field;
        field->to(device);
        FastSnarfDeformer deformer(field, options);
        run(device.is_cuda() ? "fast_snarf-cuda" : "fast_snarf-cpu", pose_name, deformer,
            sample_query_points(scene, opt->points, 0).to(device), bones, opt->repeat);
      }
      if (opt->deformer != "fast_snarf" && opt->snarf_points > 0) {
        auto options = DeformerOptions::snarf();
        options.start_bones = starts;
        auto mlp = fit_mlp_skinning_field(scene, opt->snarf_fit_steps, 0);
        mlp->to(device);
        SnarfDeformer deformer(mlp, options);
        run("snarf-mlp", pose_name, deformer, sample_query_points(scene, opt->snarf_points, 0).to(device), bones, 1);
      }
    }
  });
}

}  // namespace fskin::cli
