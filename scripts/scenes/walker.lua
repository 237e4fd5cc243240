-- An animated model file: Wuson from Debian's assimp-testmodels (X/Testwuson.X, 3,732
-- triangles skinned by 37 bones) plays its walk cycle on the statue scene's pedestal and turns
-- slowly, while the spider (a still OBJ) watches. The animation is the file's own: its keys
-- are evaluated and its mesh skinned on the CPU every frame (px.set_animation).
local paper = require "lib.paper"

px.name("walker")

local pace = px.param{name = "pace", default = 1.0, min = 0, max = 3,
                      description = "walk cycles played per second of scene time, relative"}
local turn = px.param{name = "turn", default = 0.1, min = 0, max = 1,
                      description = "turns a second about the vertical axis"}

paper.pedestal_stage()

local place = px.translate(-0.3, 0.4, 0.0)
local _, wuson = px.model{path = "assimp:X/Testwuson.X", height = 1.2, transform = place}
px.model{path = "assimp:OBJ/spider.obj", height = 0.5,
         transform = px.translate(1.1, 0.4, 0.1) * px.rotate_y(-0.6)}

-- The walk cycle, whatever its number in the file.
local walk = 1
for i, a in ipairs(px.animations(wuson)) do
  if a.name == "Wuson_Walk" then walk = i end
end

function update(t, dt)
  px.set_animation(wuson, walk, params.pace * t,
                   place * px.rotate_y(2 * math.pi * params.turn * t))
end
