#pragma once
// Scene files (TOML, docs/scene-format.md) to and from SceneDef.
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include <mca/scene.hpp>

namespace mca::io {

// Parses a scene and validates it (validate_scene). `source` names the text in messages (usually the
// file path) and gives the scene's name when the text has no `name` key (its stem). Throws mca::Error
// with "source:line:column" for syntax errors, unknown keys (with a did-you-mean) and wrong types.
SceneDef parse_scene(std::string_view toml_text, const std::string& source);

// Reads and parses a scene file; a missing or unreadable file is an mca::Error naming the path.
SceneDef load_scene_file(const std::filesystem::path& path);

// The built-in default scene (scenes/wall_ball.toml, compiled in).
SceneDef load_default_scene();

// Where a scene's `mesh = "..."` may be, in the order tried: an absolute path as it is ("~/" is the home
// folder); else relative to the
// scene file's folder, then to each folder of MCA_MESH_PATH (':'-separated), then to the models cache.
std::vector<std::filesystem::path> mesh_file_candidates(const std::string& mesh, const std::string& scene_source);
// The folder scripts/get_models.sh fills with the paper's models: $XDG_CACHE_HOME/mca/models, else
// ~/.cache/mca/models.
std::filesystem::path models_cache_dir();

// A shape's name in scene files ("box", "sphere", "cylinder", "mesh"), and the shape of a name (box for
// any other: the readers check the name first).
const char* shape_name(Shape s);
Shape to_shape(const std::string& s);

// The complete scene as TOML, every key written, such that parse_scene(scene_to_toml(s), s.source)
// gives back s exactly (doubles are written in their shortest round-tripping form).
// Its first line (after a run's comment on its step count) is kWrittenByMca: a folder whose scene.toml
// has it holds a run of mca.
std::string scene_to_toml(const SceneDef& scene);
inline constexpr std::string_view kWrittenByMca = "# Written by mca (scene_to_toml)";

}  // namespace mca::io
