#include "fskin/data/lowpoly_character.h"

#include <torch/torch.h>

#include <cmath>

#include "data/lowpoly/lowpoly_designs.h"
#include "fskin/core/error.h"

namespace fskin {

void LowPolyOptions::validate() const {
  FSKIN_CHECK(size == 0 || (std::isfinite(size) && size >= 0.01 && size <= 100.0),
              "{}: size must be in [0.01, 100] (or 0 for the default), got {}", lowpoly_kind_name(kind), size);
  FSKIN_CHECK(variation >= 0.0 && variation <= 0.1, "{}: --variation must be in [0, 0.1], got {}",
              lowpoly_kind_name(kind), variation);
}

LowPolyCharacter make_lowpoly_character(const LowPolyOptions& options) {
  options.validate();
  const bool humanoid = options.kind == LowPolyKind::Humanoid;
  auto character = humanoid ? lowpoly::make_humanoid(options.seed, options.variation)
                            : lowpoly::make_animal(options.seed, options.variation);
  const double design_size = humanoid ? 1.8 : 0.9;
  if (options.size > 0 && options.size != design_size) {
    const double scale = options.size / design_size;
    character.model.v_template = character.model.v_template * scale;
    character.model.rest_joints = character.model.rest_joints * scale;
    character.clips.trans = character.clips.trans * scale;
  }
  return character;
}

BodyModel make_lowpoly_model(const LowPolyOptions& options) {
  return BodyModel(make_lowpoly_character(options).model, "built-in " + lowpoly_kind_name(options.kind));
}

LowPolyKind parse_lowpoly_kind(const std::string& name) {
  if (name == "lowpoly-humanoid") return LowPolyKind::Humanoid;
  if (name == "lowpoly-animal") return LowPolyKind::Animal;
  fail("unknown low-poly character '{}' (lowpoly-humanoid or lowpoly-animal)", name);
}

std::string lowpoly_kind_name(LowPolyKind kind) {
  return kind == LowPolyKind::Humanoid ? "lowpoly-humanoid" : "lowpoly-animal";
}

}  // namespace fskin
