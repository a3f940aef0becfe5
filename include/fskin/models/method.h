#pragma once
// The methods fskin trains: SNARF and Fast-SNARF (forward skinning), INS, and
// the baselines of SNARF sec. 4.2.
#include <string>
#include <vector>

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

Method parse_method(const std::string& name);  // throws fskin::Error listing the names
std::string method_name(Method method);
const std::vector<std::string>& method_names();

}  // namespace fskin
