#include "tracer/scene.h"

#include <gtest/gtest.h>

#include <limits>

#include "common/input_error.h"

namespace parallax {
namespace {

Scene oneTriangle() {
  Scene scene;
  scene.addMaterial(Material::makeDiffuse(Rgb(0.5f, 0.5f, 0.5f)));
  Mesh mesh;
  mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  mesh.triangles = {{0, 1, 2}};
  scene.addMesh(mesh);
  return scene;
}

std::string errorOf(const Scene& scene) {
  try {
    scene.validate();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(Scene, ValidSceneValidates) {
  const Scene scene = oneTriangle();
  EXPECT_NO_THROW(scene.validate());
  EXPECT_EQ(scene.triangleCount(), 1);
  const Box3 box = scene.geometryBounds();
  EXPECT_EQ(box.max, Eigen::Vector3d(1, 1, 0));
}

TEST(Scene, BadInputNamesTheField) {
  Scene nan = oneTriangle();
  nan.meshes[0].positions[1].y() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(errorOf(nan).find("meshes[0].positions[1]"), std::string::npos) << errorOf(nan);

  Scene inf = oneTriangle();
  inf.meshes[0].positions[2].z() = std::numeric_limits<double>::infinity();
  EXPECT_NE(errorOf(inf).find("meshes[0].positions[2]"), std::string::npos);

  Scene range = oneTriangle();
  range.meshes[0].triangles[0][2] = 7;
  EXPECT_NE(errorOf(range).find("meshes[0].triangles[0]"), std::string::npos);
  EXPECT_NE(errorOf(range).find("out of range"), std::string::npos);

  Scene material = oneTriangle();
  material.meshes[0].material = 3;
  EXPECT_NE(errorOf(material).find("meshes[0].material"), std::string::npos);

  Scene normals = oneTriangle();
  normals.meshes[0].normals = {{0, 0, 1}};
  EXPECT_NE(errorOf(normals).find("meshes[0].normals"), std::string::npos);

  Scene empty;
  EXPECT_NE(errorOf(empty).find("nothing to draw"), std::string::npos);

  Scene ior = oneTriangle();
  ior.materials[0] = Material::makeDielectric(-1.0f);
  EXPECT_NE(errorOf(ior).find("materials[0].ior"), std::string::npos);

  Scene light = oneTriangle();
  light.addLight(Light::makeDirectional({0, 0, 0}, Rgb::Ones()));
  EXPECT_NE(errorOf(light).find("lights[0].direction"), std::string::npos);

  Scene texture = oneTriangle();
  texture.materials[0].diffuseTexture = 0;
  EXPECT_NE(errorOf(texture).find("materials[0].diffuse_texture"), std::string::npos);
}

TEST(Scene, DegenerateTrianglesAreNotValidationErrors) {
  Scene scene = oneTriangle();
  scene.meshes[0].positions.push_back({2, 2, 2});
  scene.meshes[0].triangles.push_back({3, 3, 3});
  EXPECT_NO_THROW(scene.validate());
}

}  // namespace
}  // namespace parallax
