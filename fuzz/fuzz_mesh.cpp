// libFuzzer target: se3::decode_mesh on arbitrary bytes (the geometry layer's pure, bounded
// entry point for mesh files). The first byte picks the importer (STL, Collada, OBJ, PLY, or
// assimp's own guess); the rest is the file. Built with clang -fsanitize=fuzzer,address,
// undefined against se3_sim_core, e.g.
//   clang++ -std=c++17 -g -O1 -fsanitize=fuzzer,address,undefined -Iinclude
//     -I/usr/include/eigen3 fuzz/fuzz_mesh.cpp src/geometry/*.cpp src/model/*.cpp
//     src/lie/*.cpp -lassimp -lurdfdom_model -lconsole_bridge -o fuzz_mesh
// A finding is a crash, a sanitizer report or a hang; a rejected input (null with a reason)
// is the expected outcome for nearly all inputs. decode_mesh runs assimp in this process, so
// assimp's own bugs show here too: 90 s found a null dereference in its Collada parser (a
// <float_array count="0"> holding numbers; gtest_geometry's AnImporterCrashIsAReasonNotTheEnd)
// and a leak of a few nodes on rejected Collada files (fuzz/fuzz_mesh.lsan suppresses it:
// LSAN_OPTIONS=suppressions=fuzz/fuzz_mesh.lsan). load_mesh, which the URDF loader uses, runs
// the importer in a child process, where such a crash becomes the mesh's warning.
#include <cstddef>
#include <cstdint>
#include <string>

#include "se3_sim/geometry/geometry.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  static const char* const kHints[] = {"stl", "dae", "obj", "ply", ""};
  const std::string hint = kHints[data[0] % 5];
  se3::MeshLimits limits;  // small, so a claimed giant mesh is refused before it is built
  limits.max_bytes = std::size_t(1) << 20;
  limits.max_triangles = 200000;
  // Small, so that a fan or a pile of faces at one position (fuzz/corpus/mesh/obj_fan.bin)
  // takes the bounded path (one normal a face) as well as assimp's smoothing.
  limits.max_smoothing_work = 200000;
  std::string error;
  const auto mesh = se3::decode_mesh(data + 1, size - 1, hint, limits, &error);
  if (mesh) {
    // What the renderer and collision layer rely on: indices in range, finite positions.
    for (uint32_t i : mesh->indices) {
      if (i >= mesh->positions.size()) __builtin_trap();
    }
    for (const auto& p : mesh->positions) {
      if (!p.allFinite()) __builtin_trap();
    }
    if (mesh->normals.size() != mesh->positions.size()) __builtin_trap();
    for (const auto& n : mesh->normals) {
      if (!n.allFinite()) __builtin_trap();
    }
  } else if (error.empty()) {
    __builtin_trap();  // a refusal always says why
  }
  return 0;
}
