#pragma once
// SOFA's XML scenes (.scn): a reader for the components thin-surface scenes use, which translates a
// scene into cutsim's JSON scene (docs/sofa.md has the table of components and how each maps).
// `cutsim run SCENE.scn` runs the translation as it runs a JSON scene; `cutsim import` writes it;
// `cutsim regress` compares runs with SOFA's regression references (sofa_regression.hpp).
//
// What the reader does with each element: a supported component is translated (its attributes
// read with SOFA's defaults, links such as src="@loader" and indices="@box.indices" resolved
// through the nodes as SOFA resolves them); a visual or GUI-only component (VisualStyle, Ogl*,
// RequiredPlugin, *GeometryAlgorithms, a mapping whose output is a visual model, ...) is accepted
// and listed as ignored; an attribute that cutsim does not use is listed with its line (as SOFA
// lists unused attributes); an unknown or unsupported component, a physics attribute that cutsim
// does not honour set to a value other than SOFA's default (trapezoidalScheme="1"), a template
// other than Vec3 (Vec2, Rigid3), a link to a missing component or field, a missing mesh file and
// malformed XML are errors: InvalidInput "SCENE.scn:LINE: /path/in/the/scene: message".
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "cutsim/core/scene.hpp"

namespace cutsim::core {

struct SofaImportOptions {
  /// The number of steps the translated scene runs (a SOFA scene runs until it is stopped):
  /// duration = steps * dt.
  long steps = 100;
  /// The folder the JSON scene will be written to: mesh paths are written relative to it. Empty:
  /// the scene's own folder.
  std::filesystem::path jsonDir;
};

struct SofaSceneImport {
  std::filesystem::path file;     ///< the .scn as given
  std::filesystem::path jsonDir;  ///< the folder the scene's mesh path is relative to
  nlohmann::ordered_json scene;   ///< the JSON scene (with an "ignored" list)
  /// The .scn line of each JSON value, by JSON pointer (messages of the JSON checks name them).
  std::map<std::string, std::size_t> lines;
  /// The scene's own path of each JSON value ("/root/cloth/FEM"), by JSON pointer.
  std::map<std::string, std::string> labels;
  /// Unused attributes and ignored components, each "SCENE.scn:LINE: message".
  std::vector<std::string> notes;
  /// The name of the scene's MechanicalObject (SOFA's regression files are named after it).
  std::string mechanicalObject;
};

/// Reads and translates a SOFA scene. Throws InvalidInput (see the top of this file).
SofaSceneImport importSofaScene(const std::filesystem::path& file,
                                const SofaImportOptions& options = {});
/// The scene of a translation, through every check of a JSON scene; messages name the .scn's lines.
Scene sceneFromSofa(const SofaSceneImport& imported);

}  // namespace cutsim::core
