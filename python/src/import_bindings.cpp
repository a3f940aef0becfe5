// Rigged characters from files, as `fskin import` reads them (glTF 2.0, and
// FBX, Collada and the other formats assimp reads).
#include "bindings.h"

#include "fskin/body/body_model.h"
#include "fskin/import/imported_character.h"

namespace fskin::python {

void bind_import(py::module_& m) {
  m.def(
      "import_character",
      [](const std::string& path, bool keep_open_parts) {
        fskin::ImportOptions options;
        options.keep_open_parts = keep_open_parts;
        fskin::ImportedCharacter character;
        {
          py::gil_scoped_release release;
          character = fskin::import_character(path, options);
        }
        py::list clips;
        for (const auto& clip : character.clips) {
          py::dict entry(py::arg("name") = clip.name, py::arg("poses") = clip.poses.poses,
                         py::arg("trans") = clip.poses.trans, py::arg("fps") = clip.fps,
                         py::arg("max_joint_drift") = clip.max_joint_drift);
          entry["joint_translations"] =
              clip.poses.joint_translations.defined() ? py::cast(clip.poses.joint_translations) : py::none();
          clips.append(entry);
        }
        return py::make_tuple(BodyModel(std::move(character.model), path), clips, character.notes);
      },
      py::arg("path"), py::arg("keep_open_parts") = false,
      "A rigged character file as `fskin import` reads it (.glb / .gltf; FBX, Collada, ... through assimp): "
      "(BodyModel, clips [{name, poses [T, J, 3], trans [T, 3], joint_translations or None, fps, "
      "max_joint_drift}], notes on what was merged, welded, dropped or converted); errors name the file and part");
}

}  // namespace fskin::python
