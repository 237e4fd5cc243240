#pragma once
// "Leave out what the scene does not need": one look at the scene decides which passes the
// integrator runs — shadow rays only with lights and lit surfaces, reflection rays only with
// mirrors or glass, refraction only with glass, texture sampling and loading only for textures
// a drawn, UV-mapped surface references — and caps the depth at what the materials can produce.

#include <string>
#include <vector>

#include "tracer/scene.h"

namespace parallax {

struct SceneFeatures {
  bool lights = false;              // at least one light
  bool litSurfaces = false;         // a drawn diffuse material (the only kind lights act on)
  bool phong = false;               // a drawn diffuse material with a highlight
  bool mirrors = false;             // a drawn mirror
  bool dielectrics = false;         // a drawn dielectric
  bool absorption = false;          // a drawn dielectric that absorbs
  bool emissive = false;            // drawn emission
  bool vertexColors = false;        // a drawn mesh with colours
  int depth = 1;                    // effective recursion limit
  int requestedDepth = 1;           // Scene::maxDepth
  std::vector<bool> materialDrawn;  // per Scene::materials
  std::vector<bool> textureNeeded;  // per Scene::textures
  std::vector<std::string> unsampledTextureMaterials;  // textured materials on meshes without UVs
  int meshesUnused = 0;                                // meshes no instance draws

  bool shadowPass() const { return lights && litSurfaces; }
  bool reflectionPass() const { return mirrors || dielectrics; }
  bool refractionPass() const { return dielectrics; }
  bool texturePass() const;
  int texturesNeeded() const;

  // One line per pass: what runs and why, what is left out and why.
  std::vector<std::string> explain() const;
};

SceneFeatures analyseScene(const Scene& scene);

}  // namespace parallax
