#pragma once
// The two game-style characters of lowpoly_character.h, each in its own file.
// Internal to src/data/lowpoly.
#include "fskin/data/lowpoly_character.h"

namespace fskin::lowpoly {

// At its design size (1.8 tall / 0.9 long); make_lowpoly_character scales it.
LowPolyCharacter make_humanoid(uint64_t seed, double variation);
LowPolyCharacter make_animal(uint64_t seed, double variation);

}  // namespace fskin::lowpoly
