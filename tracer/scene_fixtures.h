#pragma once
// The scenes built in as C++ (their Lua versions come with the scripts): the paper's three
// (Cornell box with a mirror floor, geometric shapes with two glass objects, the textured
// statue) and the Fig. 6 exactness triangle.

#include <string>
#include <vector>

#include "tracer/scene.h"

namespace parallax {

// The paper's Fig. 6 test: the triangle (1,0,0), (0,1,0), (0,0,1), unlit, whose colour at a point
// is that point's world position (vertex colours = positions). B_W = [0, 1]³, no lights.
Scene makeXyzTriangleScene();

// Cornell box (~1110 triangles): open toward the viewers (+z), red left and green right walls, a
// mirror floor, two boxes and a sphere, an emissive ceiling panel, 4 directional lights, depth 5.
// No textures. The box is 1 × 1 × 0.55 (shallow, to fill B_P), scaled by `scale` and moved by
// `offset`; B_W is the box (the extreme-scale tests render the same image for any of them).
Scene makeCornellScene(double scale = 1.0, const Eigen::Vector3d& offset = Eigen::Vector3d::Zero());

// Geometric shapes (1556 triangles): a glass sphere and a glass box among a diffuse torus,
// cylinder and cone on a floor before a back wall; 4 directional lights, depth 5.
Scene makeShapesScene();

// The 4 directional lights the paper's scenes share.
void addPaperLights(Scene* scene);

// A built-in scene by name ("cornell", "shapes", "statue", "xyz"); throws InputError for an
// unknown name. `assetRoot` is where assimp-testmodels lives (for "statue").
Scene makeBuiltInScene(const std::string& name, const std::string& assetRoot = "");
bool isBuiltInScene(const std::string& name);
std::vector<std::string> builtInSceneNames();

}  // namespace parallax
