// Limits on what outside input may ask of the library (docs/robustness.md): file sizes and
// nesting checked before any recursive parser (tinyxml inside urdfdom, yaml-cpp) sees a text,
// model sizes, and the work of one headless run. Input beyond them is refused with a one-line
// error that names the limit; nothing is truncated silently.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

namespace se3 {
namespace limits {

// ---- URDF text (model_from_urdf_string, the simulator's robot_description)
/// Largest URDF text: xacro-expanded real robots are well below 1 MiB.
constexpr std::size_t kMaxUrdfBytes = 16u << 20;
/// Deepest element nesting: URDFs need about 6 (robot, link, visual, geometry, mesh), Gazebo
/// extensions a few more. tinyxml recurses once per level.
constexpr int kMaxXmlDepth = 100;
/// Most attributes on one element (tinyxml looks each new one up among the previous ones).
constexpr int kMaxXmlAttributes = 256;

// ---- models
/// Most bodies of a model (URDF links or chain:N), base included.
constexpr int kMaxBodies = 100000;
/// Largest nv for the dense nv x nv results of `se3_dyn eval|bench --algo crba|minv`.
constexpr int kMaxDenseNv = 2000;

// ---- scene YAML (parse_scene, load_scene)
/// Largest scene text (the shipped scenes are 1 to 3 kB).
constexpr std::size_t kMaxSceneBytes = 1u << 20;
/// Deepest nesting of lists and maps, counted conservatively before yaml-cpp parses (a block
/// level counts twice, a flow bracket twice, a `- `, `? ` or `: ` on a line once).
constexpr int kMaxYamlDepth = 64;
/// Most items (a bound on keys, values and list entries, counted before yaml-cpp parses;
/// yaml-cpp takes about 0.5 kB of memory per node).
constexpr std::size_t kMaxYamlItems = 100000;

// ---- work of one run (se3_dyn simulate, simulate_headless)
/// Smallest time step, in a scene or on the command line (s).
constexpr double kMinDt = 1e-9;
/// Most steps of one headless run (duration / dt).
constexpr std::uint64_t kMaxSteps = 100000000;
/// Most body-steps (steps x bodies) of one headless run: about an hour of rkmk4 on this class of
/// machine.
constexpr double kMaxBodySteps = 1e10;

// ---- `se3_dyn eval` input
/// Largest CSV input read from stdin.
constexpr std::size_t kMaxCsvBytes = 256u << 20;

}  // namespace limits

/// Offset of the first byte of s that is not valid UTF-8 (overlong forms, surrogates and code
/// points past U+10FFFF included), or s.size() when all of it is: the one check that the URDF
/// guards and the scene reader run over outside text before a parser sees it (src/model/utf8.cpp).
std::size_t first_invalid_utf8(const std::string& s);

/// The one reader of outside files (URDF, scene, SRDF, mesh, package.xml; src/model/files.cpp):
/// only a regular file is read. The path is looked at with stat() first, then opened with
/// O_NONBLOCK and checked again with fstat() on the open descriptor, so that neither a FIFO,
/// a device nor a swap of the path between the two can block or have the read's side effects.
/// Returns false and sets *why to what the path is instead ("not found", "a directory", "a FIFO
/// (named pipe)", "a character device", "a block device", "a socket", "unreadable
/// (Permission denied)", "N bytes, more than the M"). A file longer than max_bytes is refused
/// unless `prefix`, which reads its first max_bytes only.
bool read_file(const std::string& path, std::string& out, std::string* why,
               std::size_t max_bytes = std::size_t(256) << 20, bool prefix = false);
/// "" for a regular file that can be opened for reading, else what read_file would say.
std::string not_a_regular_file(const std::string& path);
/// The nearest folder at or above dir that holds a package.xml ("" if none): where a robot's or
/// scene's package:// and relative meshes are looked for.
std::string package_root(std::string dir);

/// The one rule for a time step, which the scene reader, the simulator, se3_dyn and the simulator
/// node's ~dt apply: "" when dt is finite and at least limits::kMinDt, else why not, worded to
/// follow the value's name ("is not a finite number", "is not positive", "is below the smallest
/// step, 1e-9 s (docs/robustness.md)").
std::string dt_problem(double dt);

/// x with three significant figures ("1.5e+300"), for messages that quote an out-of-range value
/// (std::to_string prints every digit).
std::string three_figures(double x);

}  // namespace se3
