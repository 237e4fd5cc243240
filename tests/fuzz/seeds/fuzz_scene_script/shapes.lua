-- The paper's geometric shapes: a glass sphere and a tinted glass block among a gold torus, a
-- red cylinder and a green cone, on a floor before a back wall; the four directional lights,
-- depth 5. 1556 triangles.
local paper = require "lib.paper"

px.name("shapes")
local floor = px.diffuse{name = "floor", color = {0.7, 0.7, 0.65}}
local wall = px.diffuse{name = "wall", color = {0.5, 0.55, 0.7}}
local glass = px.glass{name = "glass", ior = 1.5}
local tinted = px.glass{name = "tinted_glass", ior = 1.45, absorption = {0.2, 0.9, 1.8}}
local gold = px.phong{name = "gold", color = {0.8, 0.6, 0.2}, specular = {0.6, 0.6, 0.5}, shininess = 60}
local red = px.diffuse{name = "red", color = {0.8, 0.15, 0.1}}
local green = px.phong{name = "green", color = {0.2, 0.7, 0.3}, specular = {0.4, 0.4, 0.4}, shininess = 20}

local half_pi = math.pi / 2
-- World: x in [-2, 2], y in [0, 2.25], z in [-1.25, 1.25] (B_P's 1.6 : 0.9 : 0.5 shape).
px.grid{width = 4, height = 2.5, nx = 12, ny = 12, material = floor, name = "floor",
        transform = px.translate(0, 0, 0) * px.rotate_x(-half_pi)}
px.grid{width = 4, height = 2.25, nx = 2, ny = 2, material = wall, name = "back_wall",
        transform = px.translate(0, 1.125, -1.25)}
px.sphere{radius = 0.55, slices = 24, stacks = 12, material = glass, name = "glass_sphere",
          transform = px.translate(-0.5, 0.55, 0.35)}
px.box{size = {0.6, 0.9, 0.35}, material = tinted, name = "glass_block",
       transform = px.translate(0.75, 0.45, 0.55) * px.rotate_y(0.5)}
px.torus{major = 0.42, minor = 0.14, segments = 24, sides = 12, material = gold, name = "torus",
         transform = px.translate(-1.35, 0.5, -0.45) * px.rotate_x(1.2)}
px.cylinder{radius = 0.28, height = 1.0, slices = 24, material = red, name = "cylinder",
            transform = px.translate(0.3, 0.5, -0.6)}
px.cone{radius = 0.35, height = 0.9, slices = 24, material = green, name = "cone",
        transform = px.translate(1.5, 0.45, -0.35)}

paper.add_lights()
px.ambient({0.05, 0.05, 0.05})
px.background({0.05, 0.06, 0.08})
px.world_box{min = {-2.0, 0.0, -1.25}, max = {2.0, 2.25, 1.25}}
px.max_depth(5)
