-- The paper's Cornell box: open toward the viewers (+z), red left and green right walls, a
-- mirror floor, two boxes and a blue Phong sphere, an emissive ceiling panel, the four
-- directional lights, depth 5. 1110 triangles, no textures.
local paper = require "lib.paper"

local depth = px.param{name = "depth", default = 0.55, min = 0.2, max = 1.0,
                       description = "depth of the box (its width and height are 1)"}

px.name("cornell")
local white = px.diffuse{name = "white", color = {0.73, 0.73, 0.73}}
local red = px.diffuse{name = "red", color = {0.65, 0.06, 0.05}}
local green = px.diffuse{name = "green", color = {0.12, 0.45, 0.15}}
local mirror = px.mirror{name = "mirror_floor", reflectance = {0.85, 0.85, 0.85}}
local lamp = px.emissive{name = "lamp", color = {4.0, 3.6, 3.0}}
local blue = px.phong{name = "blue_phong", color = {0.15, 0.2, 0.6}, specular = {0.5, 0.5, 0.5}, shininess = 40}

-- The box is 1 wide, 1 tall and `depth` deep (shallow, so it fills the displayable box from
-- top to bottom instead of being limited by B_P's small depth); everything is placed in it.
local world_from_box = px.translate(0, 0, 0) * px.scale(1)
local shallow = px.scale(1, 1, depth)
local add = paper.placer(world_from_box)
local half_pi = math.pi / 2

-- Walls: 10 × 10 grids (200 triangles each), facing into the box.
local function wall(material, name, transform)
  return add(px.grid, {width = 1, height = 1, nx = 10, ny = 10, material = material, name = name}, transform)
end
wall(mirror, "floor", shallow * px.translate(0.5, 0, 0.5) * px.rotate_x(-half_pi))
wall(white, "ceiling", shallow * px.translate(0.5, 1, 0.5) * px.rotate_x(half_pi))
wall(white, "back", px.translate(0.5, 0.5, 0))
wall(red, "left", shallow * px.translate(0, 0.5, 0.5) * px.rotate_y(half_pi))
wall(green, "right", shallow * px.translate(1, 0.5, 0.5) * px.rotate_y(-half_pi))
-- The ceiling lamp just below the ceiling (2 triangles).
add(px.grid, {width = 0.3, height = 0.3, nx = 1, ny = 1, material = lamp, name = "lamp"},
    px.translate(0.5, 0.998, 0.26) * px.rotate_x(half_pi))
-- A tall and a short box (12 triangles each) and a sphere (84).
add(px.box, {size = {0.28, 0.58, 0.28}, material = white, name = "tall_box"},
    px.translate(0.32, 0.29, 0.2) * px.rotate_y(0.3))
add(px.box, {size = {0.27, 0.27, 0.27}, material = white, name = "short_box"},
    px.translate(0.68, 0.135, 0.35) * px.rotate_y(-0.3))
add(px.sphere, {radius = 0.12, slices = 6, stacks = 8, material = blue, name = "sphere"},
    px.translate(0.68, 0.39, 0.35))

paper.add_lights()
px.ambient({0.04, 0.04, 0.04})
px.background({0.02, 0.02, 0.03})
px.world_box{min = {0, 0, 0}, max = {1, 1, depth}}
px.max_depth(5)
