-- An animated scene where nearly everything stands still: the statue scene's two models on a
-- pedestal over a polished floor (5,110 triangles), and one small Phong ball circling them.
-- The frame cache's good case (orbit.lua is its bad one: there most triangles move): per
-- frame only the ball is traced for the primary rays and the static lights' shadows.
local paper = require "lib.paper"

px.name("sentinel")

local speed = px.param{name = "speed", default = 0.2, min = 0, max = 2,
                       description = "ball turns per second"}

paper.pedestal_stage()
px.model{path = "assimp:OBJ/WusonOBJ.obj", height = 1.1,
         transform = px.translate(-0.55, 0.4, 0.0) * px.rotate_y(-1.25)}
px.model{path = "assimp:OBJ/spider.obj", height = 0.6,
         transform = px.translate(1.0, 0.4, 0.1) * px.rotate_y(-0.6)}

local red = px.phong{name = "ball", color = {0.8, 0.2, 0.2}, specular = {0.5, 0.5, 0.5},
                     shininess = 30}
local ball = px.sphere{radius = 0.12, material = red, name = "ball"}

function update(t, dt)
  local angle = 2 * math.pi * params.speed * t
  px.set_transform(ball, px.translate(1.4 * math.cos(angle), 0.95, 0.7 * math.sin(angle)))
end
