#pragma once
// Everything that defines a training run: defaults (the CPU demo size),
// overlaid by a config file, overlaid by command-line assignments, and saved
// into the run directory so evaluation and resume rebuild exactly the same
// model. The struct is flat; its documents are nested per component, with
// key-path validation (training/config_schema.h).
#include <cstdint>
#include <string>
#include <vector>

#include <memory>

#include "fskin/data/canonical_skeleton.h"
#include "fskin/models/model_registry.h"

namespace fskin {

struct TrainConfig {
  std::string data;  // dataset directory the run trains on (recorded for evaluation)
  std::string method = "fast-snarf";  // method.h: fast-snarf, snarf, pose-onet, back-lbs, back-d, piecewise
  uint64_t seed = 0;
  int64_t steps = 1000;  // the CPU demo (~3.5 min on 2 cores); full(): 45k
  // Batch: frames x (near-surface + uniform) points (papers: 8 x (2000 + 250)).
  int64_t frames_per_batch = 8;
  int64_t surface_points = 1000;
  int64_t uniform_points = 125;
  // The CPU demo trains a few hundred steps, not 45k: a higher rate than the
  // papers' 1e-3 (and the positional encoding below) make those steps count.
  double learning_rate = 3e-3;
  double grad_clip = 0;  // max gradient norm; 0: none (Fast-SNARF), 0.1 (SNARF), 4 (INS)
  // Linear learning-rate warm-up from warmup_factor x to 1 x over warmup_steps
  // (INS: 0.2, 2400 steps); 0 steps: none.
  // Demo: 100 steps from 0.1 x; full(): none.
  int64_t warmup_steps = 100;
  double warmup_factor = 0.1;
  // Cosine learning-rate decay to decay_factor x over the last decay_fraction
  // of the steps (0: constant rate, the papers' setting). On the short CPU
  // schedules the falling rate is what turns a noisy plateau into a fit.
  // Demo: the second half decays to 0.05 x; full(): 0.
  double decay_fraction = 0.5;
  double decay_factor = 0.05;
  // Bootstrap losses (SNARF sec. 3.3) during the first epochs.
  double bootstrap_epochs = 1;
  int64_t bone_points_per_bone = 5;
  double joint_weight_loss_weight = 10;
  // Which bone segments the bootstrap losses and the skinning prior use:
  // "all" (the papers: every segment is assumed inside the body) or
  // "in-body" (those inside the canonical mesh, CanonicalSkeleton::segment_in_body:
  // real rigs' roots on the ground and bones outside the skin are left out).
  std::string bootstrap_bones = "all";
  // Warm start of the skinning network on the skeleton's nearest-bone prior
  // (skinning_prior.h) before step 0; 0 turns it off (the papers' setting).
  int64_t skinning_prior_steps = 100;
  int64_t checkpoint_every = 200;
  int64_t keep_checkpoints = 2;
  // Every validate_every steps (0: never) evaluate on the first
  // validation_frames frames of the dataset's val split and keep the best by
  // IoU_surf as checkpoint-best.fskin (`fskin eval --checkpoint best`).
  int64_t validate_every = 0;
  int64_t validation_frames = 10;
  // Occupancy network; the pose vector's width comes from the skeleton.
  int64_t occupancy_hidden_dim = 128;
  int64_t occupancy_hidden_layers = 4;
  std::vector<int64_t> occupancy_skip_layers{2};
  // Off in the CPU demo: in a few hundred steps the pose-conditioned network
  // learned the training poses and generalised worse to unseen ones (SNARF-NC
  // is the pose-free variant the INS paper compares with). On in full().
  bool pose_conditioning = false;
  int64_t pose_embedding_dim = 8;
  int64_t pose_layer = 2;
  int64_t encoding_frequencies = 4;  // NeRF frequencies (papers: 0, 4 for clothed data)
  // Coarse to fine (networks/frequency_encoding.h): the frequency window
  // opens `encoding_window_start` bands at step 0 and widens linearly to all of
  // them at encoding_window_fraction x steps; fraction 0 opens all from the start.
  double encoding_window_start = 0;
  double encoding_window_fraction = 0;
  // Hash-grid encoding of the canonical point, concatenated to the network's
  // input (canonical/occupancy_network.h): levels (0: none), table rows 2^T
  // per level, and the coarsest and finest grid resolutions along the
  // canonical body's longest side.
  int64_t occupancy_hash_levels = 0;
  int64_t occupancy_hash_log2_table_size = 17;
  int64_t occupancy_hash_base_resolution = 16;
  int64_t occupancy_hash_finest_resolution = 512;
  double init_radius = 1.0;
  // Skinning MLP and (Fast-SNARF) its voxel grid, depth/height/width = z/y/x.
  int64_t skinning_hidden_dim = 128;
  int64_t skinning_hidden_layers = 4;
  // The skinning network's learning rate relative to learning_rate (papers: 1).
  // Demo: 0.3. At the full rate some seeds let a limb's weights drift early
  // and that limb detaches in canonical space (OOD IoU_bbox 0.74 vs 0.87 for
  // two seeds); at 0.3 both seeds reach 0.92 (docs/benchmarks.md).
  double skinning_learning_rate_factor = 0.3;
  // Fast-SNARF's skinning grid: grid_resolution voxels along the canonical
  // body's longest side, the other sides as many as keep voxels near-cubic
  // (VoxelBox::fit), so the grid follows any character's proportions and
  // orientation. 32: about the papers' 8 x 32 x 32 demo grid for a person
  // (nearly as good as 16 x 64 x 64 in Fast-SNARF's ablation). 0: the
  // explicit `grid` [depth, height, width] in the papers' person layout (x and
  // y square, z a quarter of the longest side; VoxelBox::around), which is
  // what run configs written before grid_resolution existed used.
  int64_t grid_resolution = 32;
  // A fresh Fast-SNARF or INS run whose canonical mesh has more than
  // thin_part_fraction of its surface on parts thinner than a grid_resolution
  // cell (data/thin_parts.h: fingers, capes, flat ears, tails) trains with
  // grid_resolution = thin_part_grid_resolution instead, and says so; 0 keeps
  // grid_resolution whatever the character. 48 and 0.1: on the low-poly
  // humanoid (33 % thin at 32) 48 raised OOD IoU_surf from 0.787 +- 0.016 to
  // 0.858 +- 0.012 over 3 seeds, on the low-poly fox (16 %) 0.867 -> 0.882
  // (within the spread); the built-in humanoid (5 % thin) gained nothing at
  // 48 and trains 2.6x faster at 32, so it keeps 32 (docs/benchmarks.md,
  // "Real-asset-like characters").
  int64_t thin_part_grid_resolution = 48;
  double thin_part_fraction = 0.1;
  // A Fast-SNARF run that the rule above moves to thin_part_grid_resolution
  // also decays its learning rate over this fraction of the steps instead of
  // decay_fraction; -1 keeps decay_fraction. 1.0: over 3 seeds the low-poly
  // fox's within IoU_surf rose from 0.923 +- 0.015 to 0.932 +- 0.001 (OOD
  // 0.882 -> 0.891), the low-poly humanoid's fell from 0.939 +- 0.002 to
  // 0.933 +- 0.002 (OOD 0.858 -> 0.854), both above the 0.93 / 0.85 bar; on
  // the built-in humanoid, which the rule leaves at grid 32, the same schedule
  // cost 0.005 of within IoU_surf, so the plain default stays 0.5
  // (docs/benchmarks.md, "Real-asset-like characters").
  double thin_part_decay_fraction = 1.0;
  // Margin of that grid's box on every side, as a fraction of the canonical
  // body's longest side, and at least 1.25 voxels (roots outside the box are
  // invalid, so a tight box also rejects spurious far roots; a coarse grid
  // needs cells beyond the surface: at 16 voxels and 0.05 alone, the limb of
  // tests/training/invariance_test.cpp lost 11 IoU points when turned). 0.05: on the humanoid 0.1 cost up to
  // 4.5 OOD IoU_surf points (seed 1), 0.05 matched the papers' person layout;
  // on the quadruped both met the targets (docs/benchmarks.md, "Any character").
  double grid_padding = 0.05;
  std::vector<int64_t> grid{8, 32, 32};
  // Emptiness prior on the canonical shape (losses/canonical_sparsity.h):
  // weight of the BCE towards "outside" at canonical_sparsity_points points
  // per frame, uniform in the canonical meshing box; 0 = off (the papers,
  // full()). Demo: 0.3, which removes most canonical floaters and raised
  // IoU_bbox by 2-3 points (docs/benchmarks.md, "Canonical floaters"); off
  // for INS (use_method): with clipping it cost 0.7 OOD IoU_surf points on the
  // clothed character (docs/benchmarks.md, "INS: clipping, pose frame and bone
  // dropout").
  double canonical_sparsity_weight = 0.3;
  int64_t canonical_sparsity_points = 256;
  // INS: coupling layers per PIN, widths of the pose encoder (per bone) and of
  // the coupling layers' SIREN and maps, rotation encoding, and the PINs'
  // learning rate relative to learning_rate. Defaults: the CPU size measured on
  // the clothed character (docs/benchmarks.md, "INS: clipping, pose frame and
  // bone dropout"; maps 8 as accurate as 16 over three seeds and re-posing
  // 1.5x faster, "INS re-posing: cheaper kernel math, fused LBS, maps 8");
  // full() and configs/ins-paper.json: the paper's (18 layers, 5 x 24 = 120,
  // pose MLP 128, SIREN 64, maps 32, 0.1).
  int64_t pin_layers = 6;
  int64_t pin_per_bone_dim = 5;
  int64_t pin_pose_hidden_dim = 64;
  int64_t pin_space_hidden_dim = 32;
  // SIREN output layer: "linear" (the SIREN paper's; folds into the maps:
  // re-posing 3.3x and training 1.7x faster on the clothed character,
  // docs/ins.md) or "sine" (a bounded embedding; run configs written without
  // this key load as "sine", TrainConfig::load_run).
  std::string pin_space_output = "linear";
  // w0 of the SIREN's first layer (SIREN paper: 30): its initial frequencies
  // are w0 x U(-1/2, 1/2) radians per unit of the PINs' normalised coordinates
  // (the body's longest side spans [-1, 1]), which sets how finely the PINs
  // can bend space early in training. Default 10: 30 left ripples in the
  // re-posed skirt (full(): 30).
  double pin_space_omega = 10.0;
  int64_t pin_map_hidden_dim = 8;
  std::string pin_rotation = "euler";
  // "parent": each bone's transform relative to its parent's (pose_encoding.h,
  // PoseFrame); "global": its canonical -> posed transform (the paper, full()).
  // With "parent" and bone dropout INS matched SNARF-NC out of distribution;
  // with "global" it lost 3 IoU_surf points (docs/benchmarks.md).
  std::string pin_pose_frame = "parent";
  // Probability of dropping one bone's pose embedding per frame in training
  // (PoseEncoderOptions::bone_dropout; full(): 0, the paper).
  double pin_bone_dropout = 0.6;
  double pin_learning_rate_factor = 0.03;
  // Piecewise baseline: one MLP per bone.
  int64_t part_hidden_dim = 64;
  int64_t part_hidden_layers = 3;
  // "default": the papers' 9 SMPL bones on skeletons with SMPL's joint names,
  // automatic:9 on any other skeleton; or "smpl-training", "all", "automatic:K".
  std::string start_bones = "default";
  int64_t max_iterations = 0;  // 0: the method's reference value
  // Which SNARF roots count (method "snarf" only): "converged" (the SNARF
  // paper and its code: every converged root, wherever it lies) or "in-box"
  // (Fast-SNARF's rule: converged, inside the skinning grid's box, duplicates
  // removed), which isolates the grid from the search rule when the two
  // methods are compared (docs/benchmarks.md).
  std::string snarf_roots = "converged";
  // The implicit gradient of the roots: "default" (each paper's: exact J^-1 at
  // the root for SNARF, eq. 14; Broyden's last J^-1 for Fast-SNARF, Fast-SNARF
  // eq. 17, and for INS, whose LBS search is Fast-SNARF's), "exact" or
  // "approximate". For ablations that separate the gradient from the grid
  // (docs/benchmarks.md).
  std::string implicit_gradient = "default";
  int64_t eval_chunk_points = 20000;

  // The papers' full size: 8 x 256 occupancy network, 2000 + 250 points,
  // 16 x 64 x 64 grid, learning rate 1e-3, raw coordinates, 45k steps.
  static TrainConfig full();

  // Sets `method` and the defaults measured for it on top of this config:
  // for "ins", gradient clipping at 4 (the paper's; without it 5 of 11 INS runs
  // collapsed mid-training, docs/benchmarks.md) and no emptiness prior.
  // Config files and --set assignments are applied after, so they still win.
  void use_method(const std::string& name);

  // The nested document (config_schema.h), as run directories hold it.
  std::string to_json() const;
  // The flat document of run directories written before the nested layout.
  std::string to_flat_json() const;
  // Overlays a JSON object, nested or flat, on `base` (e.g. TrainConfig{} or
  // full()); unknown keys and bad values are errors naming `context` and the
  // key path.
  static TrainConfig from_json(const std::string& text, const std::string& context, const TrainConfig& base);
  static TrainConfig load(const std::string& path, const TrainConfig& base);
  // A run directory's saved config.json (complete, as `fskin train` writes it).
  // Keys added to fskin after that run was written take the value that
  // reproduces the run's behaviour, not today's default (pin_space_output:
  // "sine" before the linear output became the default).
  static TrainConfig load_run(const std::string& path);
  // Applies "key=value": a key path (model.deformer.grid.resolution) or a flat
  // name (grid_resolution); the value in JSON syntax, or a bare string.
  void set(const std::string& assignment);
  void validate() const;

  // Epoch length in steps for a training set of `frames` frames.
  int64_t bootstrap_steps(int64_t frames) const;
};

// The model a config describes for a skeleton (bones, pose width, voxel box
// spanning skeleton.extent, start bones by joint name); validates the config.
ModelOptions model_options(const TrainConfig& config, const CanonicalSkeleton& skeleton);
// The canonical frequency encoding's window at step `step` (0-based): every
// band (infinity) from step encoding_window_fraction x steps - 1 on, so the
// last step and everything after training see the plain encoding.
double frequency_window(const TrainConfig& config, int64_t step);
// make_model(model_options(config, skeleton)).
std::shared_ptr<OccupancyModel> make_model(const TrainConfig& config, const CanonicalSkeleton& skeleton);

// For the grid-skinned methods (Fast-SNARF, INS): the fraction of
// skeleton.extent's points outside the skinning grid box, which get no
// skinning weights. 0 with the fitted box (grid_resolution > 0); the papers'
// person layout (grid_resolution=0) can leave parts of other characters out.
double fraction_outside_grid(const ModelOptions& options, const CanonicalSkeleton& skeleton);

}  // namespace fskin
