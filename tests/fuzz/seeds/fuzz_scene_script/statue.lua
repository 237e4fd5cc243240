-- The paper's textured statue scene: Wuson (3,732 triangles) beside the spider (1,368
-- triangles, five textures, Windows paths in its MTL) from Debian's assimp-testmodels, on a
-- marble pedestal over a polished floor; 5,114 triangles, the four directional lights, depth 5.
local paper = require "lib.paper"
local f32 = paper.f32

px.name("statue")

-- The pedestal's marble: a 128 × 128 procedural texture (16-texel checks with a sine vein),
-- computed in single precision step by step as the C++ fixture does.
local size = 128
local pixels = {}
for y = 0, size - 1 do
  for x = 0, size - 1 do
    local check = ((x // 16) + (y // 16)) % 2 == 0
    local inner = f32(f32(0.3) * f32(math.sin(f32(f32(0.11) * y))))
    local vein = f32(0.5 + f32(0.5 * f32(math.sin(f32(f32(f32(0.15) * x) + inner)))))
    local base = f32((check and f32(0.75) or f32(0.55)) * f32(f32(0.85) + f32(f32(0.15) * vein)))
    pixels[#pixels + 1] = base
    pixels[#pixels + 1] = f32(base * f32(0.96))
    pixels[#pixels + 1] = f32(base * f32(0.9))
  end
end
local marble = px.image{width = size, height = size, pixels = pixels}
local stone = px.diffuse{name = "pedestal", color = {1, 1, 1}, texture = marble}
px.box{size = {3.2, 0.4, 1.6}, material = stone, transform = px.translate(0, 0.2, 0)}
local floor = px.mirror{name = "polished_floor", reflectance = {0.6, 0.6, 0.65}}
px.grid{width = 4.0, height = 2.0, material = floor, transform = px.rotate_x(-math.pi / 2)}

px.model{path = "assimp:OBJ/WusonOBJ.obj", height = 1.1,
         transform = px.translate(-0.55, 0.4, 0.0) * px.rotate_y(-1.25)}
px.model{path = "assimp:OBJ/spider.obj", height = 0.6,
         transform = px.translate(1.0, 0.4, 0.1) * px.rotate_y(-0.6)}

paper.add_lights()
px.ambient({0.06, 0.06, 0.06})
px.background({0.04, 0.05, 0.07})
px.world_box{min = {-2.0, 0.0, -1.0}, max = {2.0, 2.25, 1.0}}
px.max_depth(5)
