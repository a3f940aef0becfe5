// fskin render: pictures of meshes and body models without a display or GPU.
#include <torch/torch.h>

#include <cstdio>

#include "cli/commands.h"
#include "fskin/body/body_model.h"
#include "fskin/core/error.h"
#include "fskin/export/image.h"
#include "fskin/export/palette.h"
#include "fskin/export/render.h"
#include "fskin/io/mesh_io.h"

namespace fskin::cli {

void register_render(CLI::App& app) {
  struct Options {
    std::vector<std::string> meshes;
    std::string model, out, view = "front";
    bool color_by_bone = false, blend = false;
    int width = 512, height = 512, turntable = 0, supersampling = 3;
  };
  auto opt = std::make_shared<Options>();
  auto* cmd = app.add_subcommand(
      "render", "Render meshes (and/or a model's template) to a PNG: a row per mesh, a column "
                "per view");
  cmd->add_option("--mesh", opt->meshes, "mesh file (.ply or .obj); repeat for more rows");
  auto* model = cmd->add_option("--model", opt->model,
                                "SMPL-format model .npz: render its template mesh");
  cmd->add_flag("--color-by-bone", opt->color_by_bone,
                "colour the model's template by its arg-max skinning bone")
      ->needs(model);
  cmd->add_flag("--blend", opt->blend,
                "with --color-by-bone: blend the bone colours by the skinning weights");
  cmd->add_option("--out", opt->out, "output picture (.png)")->required();
  cmd->add_option("--view", opt->view, "front, three-quarter, side, back or all")
      ->check(CLI::IsMember({"front", "three-quarter", "side", "back", "all"}));
  cmd->add_option("--turntable", opt->turntable,
                  "instead of --view: N views evenly around the subject")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--width", opt->width, "width of each picture cell in pixels")
      ->check(CLI::Range(1, 8192));
  cmd->add_option("--height", opt->height, "height of each picture cell in pixels")
      ->check(CLI::Range(1, 8192));
  cmd->add_option("--supersampling", opt->supersampling,
                  "samples per pixel along each axis (anti-aliasing)")
      ->check(CLI::Range(1, 8));
  cmd->callback([opt] {
    FSKIN_CHECK(!opt->meshes.empty() || !opt->model.empty(),
                "render: give at least one --mesh or a --model");
    FSKIN_CHECK(!opt->blend || opt->color_by_bone, "render: --blend needs --color-by-bone");
    std::vector<Mesh> meshes;
    if (!opt->model.empty()) {
      const auto body = BodyModel::load(opt->model);
      Mesh mesh = body.template_mesh();
      if (opt->color_by_bone)
        mesh.colors = opt->blend ? color_by_blended_weights(body.data().weights)
                                 : color_by_argmax_weight(body.data().weights);
      meshes.push_back(mesh);
    }
    for (const auto& path : opt->meshes) meshes.push_back(io::read_mesh(path));

    std::vector<ViewAngles> views;
    if (opt->turntable > 0) {
      views = turntable_views(opt->turntable);
    } else if (opt->view == "all") {
      for (View view : {View::Front, View::ThreeQuarter, View::Side, View::Back})
        views.push_back(view_angles(view));
    } else {
      views.push_back(view_angles(parse_view(opt->view)));
    }
    RenderOptions options;
    options.width = opt->width;
    options.height = opt->height;
    options.supersampling = opt->supersampling;
    const Image picture = render_grid(meshes, views, options);
    write_png(opt->out, picture);
    std::printf("wrote %s (%dx%d, %zu meshes x %zu views)\n", opt->out.c_str(), picture.width,
                picture.height, meshes.size(), views.size());
  });
}

}  // namespace fskin::cli
