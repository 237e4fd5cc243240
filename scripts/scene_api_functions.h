#pragma once
// Inside the scene API binding (scene_api.cpp registers them): the functions that add
// textures and geometry, kept in their own file (scene_api_geometry.cpp). Each reads its
// arguments with the non-raising readers of lua_values.h and throws on bad input.

#include "scripts/scene_api.h"

struct lua_State;

namespace parallax::scene_api_detail {

SceneBuild& buildOf(lua_State* L);

int apiTexture(lua_State* L, SceneBuild& b);
int apiImage(lua_State* L, SceneBuild& b);
int apiGrid(lua_State* L, SceneBuild& b);
int apiPlane(lua_State* L, SceneBuild& b);
int apiBox(lua_State* L, SceneBuild& b);
int apiSphere(lua_State* L, SceneBuild& b);
int apiTorus(lua_State* L, SceneBuild& b);
int apiCylinder(lua_State* L, SceneBuild& b);
int apiCone(lua_State* L, SceneBuild& b);
int apiMesh(lua_State* L, SceneBuild& b);
int apiModel(lua_State* L, SceneBuild& b);
int apiAnimations(lua_State* L, SceneBuild& b);
int apiSetAnimation(lua_State* L, SceneBuild& b);
int apiInstance(lua_State* L, SceneBuild& b);
int apiSetTransform(lua_State* L, SceneBuild& b);
int apiTriangleCount(lua_State* L, SceneBuild& b);

}  // namespace parallax::scene_api_detail
