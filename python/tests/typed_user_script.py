"""A user's script, type-checked (not run) by test_stubs.py with mypy against the shipped
stubs: the calls a user of the README, the deformers and the ops writes."""
import torch

import fskin

body = fskin.humanoid()
poses = fskin.training_poses(body, sequences=1, frames=2)
vertices, joints, bones = body.forward(poses)
count: int = body.num_vertices
box = fskin.VoxelBox.fit(vertices[0], 32, 0.05)
grid = torch.rand(8, 32, 32, body.num_joints).softmax(-1)
deformer = fskin.FastSnarfDeformer(grid, box, start_bones=4)
module: torch.nn.Module = deformer
color, opacity = fskin.composite_rays(torch.rand(4, 8), torch.rand(4, 8, 3), torch.rand(4, 8), torch.rand(4, 3))
summary: dict = fskin.build_dataset("model.npz", poses, "data", thin_surface_share=0.5)
text: str = fskin.build_image_dataset("model.npz", poses, "images", width=64, height=48, background=(0.0, 0.0, 0.0))
packed, shape = fskin.Pin(num_layers=2, embedding_dim=4).fused_arguments(torch.zeros(1, 4))
