#pragma once
// The methods fskin trains: SNARF and Fast-SNARF (forward skinning), INS, and
// the baselines of SNARF sec. 4.2. Their names (a config's model.type) and
// builders are in the registry, models/model_registry.h.
namespace fskin {

enum class Method {
  FastSnarf,  // "fast-snarf": voxel skinning grid, fused search (Fast-SNARF)
  Snarf,      // "snarf": skinning MLP, exact implicit gradient (SNARF)
  PoseOnet,   // "pose-onet": occupancy in posed space, pose-conditioned
  BackLbs,    // "back-lbs": pose-conditioned skinning weights in posed space, inverse LBS
  BackD,      // "back-d": pose-conditioned displacement from posed to canonical space
  Piecewise,  // "piecewise": rigid parts, one occupancy network per bone, max over parts
  Ins,        // "ins": invertible networks around the LBS, pose-free shape (INS)
};

}  // namespace fskin
