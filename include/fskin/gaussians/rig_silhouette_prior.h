#pragma once
// The rig silhouette prior of a Gaussian avatar (losses.rig_silhouette): in
// the unseen view of gaussians/unseen_view_prior.h, the L1 distance between
// the picture's opacity and the coverage of the rig's own mesh, posed by the
// step's bones with the rig's weights, summed over the pixels and divided by
// the training picture's pixel count (as the mask loss is).
//
// Why: the training masks place the outline only where some training camera
// sees one. Gaussians on the surfaces that face between the cameras are never
// on a training outline, and their footprints overhang from the cameras that
// see them there (docs/benchmarks.md, "A fixed light": held-out renders cover
// more area than their masks, and most of the lit images' error lies within 2
// pixels of the outline). The rig's mesh gives an outline from every side.
//
// Measured on the demo's images (docs/benchmarks.md, "Gaussian avatars"; 3
// seeds): the outline's error per held-out picture halves, and the subject's
// box gains 4.1 / 4.0 dB lit, 1.5 / 1.7 dB unlit (novel views / poses), the
// built-in quadruped 0.7 / 0.7 dB, drawn on one step in 4 (the default
// losses.unseen_view.every) for about 1.1-1.2 times the training time.
//
// It assumes what the surface layer prior (surface_layer.h) assumes: the
// mesh is the character's surface, as a rigged character's own mesh is. A
// body model fitted to photographs of a clothed subject is not: on a dataset
// imported from a capture the weight is 0 unless given
// (configure_gaussian_options). Nor is it exact for a body model with
// pose-corrective shapes posed from a canonical pose other than its rest
// pose (the demo's character: 0.4-0.9 % of the area short of the masks).
#include <torch/torch.h>

#include "fskin/geometry/pinhole_camera.h"
#include "fskin/skeleton/rigged_mesh.h"

namespace fskin {

// The fraction of each pixel [H, W] (float, in [0, 1]) that `character`'s
// mesh covers when posed by bones [J, 4, 4] (linear blend skinning with its
// weights) and seen by `camera`, from s x s samples per pixel (image datasets
// draw their masks so, with s = 3 unless told otherwise:
// radiance/image_dataset_builder.h). Not differentiable.
torch::Tensor posed_rig_coverage(const RiggedMesh& character, const torch::Tensor& bones,
                                 const PinholeCamera& camera, int supersampling = 3);

}  // namespace fskin
