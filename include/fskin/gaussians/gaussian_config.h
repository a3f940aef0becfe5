#pragma once
// A Gaussian avatar's training options as a config document, nested per
// component like the volume avatar's (radiance/avatar_config.h):
//
//   model      type "gaussian-avatar"; gaussians {initial, sh_degree,
//              initial_opacity}; skinning {grid_resolution}
//   density    start, stop_fraction, every, gradient_threshold,
//              dense_fraction, min_opacity, max_scale_fraction,
//              opacity_reset_every, max_gaussians (density_control.h)
//   losses     ssim {weight}, mask {weight}
//   optimizer  type "adam", learning_rates {means, scales, rotations, opacity, sh}
//   schedule   type "cosine-decay", decay_fraction, decay_factor
//   data       path, crop_margin
//   run        checkpoint_every, log_every
//   seed, steps
//
// A run's gaussian_avatar.json is this document plus its format and the
// fskin version; `--config FILE` and `--set a.b.c=v` overlay it.
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "fskin/gaussians/gaussian_training.h"

namespace fskin {

nlohmann::json gaussian_config_document(const GaussianTrainOptions& options);

// `document` overlaid on `base`: unknown keys, wrong kinds and wrong types
// are errors naming `context` and the key path; the result is validated.
GaussianTrainOptions gaussian_options_from_document(const nlohmann::json& document, const GaussianTrainOptions& base,
                                                    const std::string& context);

// The run file's document (data path made absolute, format, version) and its reader.
nlohmann::json gaussian_run_document(const GaussianTrainOptions& options);
GaussianTrainOptions read_gaussian_run_config(const std::string& path, const std::string& run_dir);

// base, then the document at config_path (if any), then each "a.b.c=v" of settings.
GaussianTrainOptions configure_gaussian_options(const GaussianTrainOptions& base, const std::string& config_path,
                                                const std::vector<std::string>& settings);

}  // namespace fskin
