-- Shared by the scene library: the four directional lights of the paper's scenes, and the
-- helpers that let a script state a number exactly as the C++ fixtures did.
local paper = {}

-- The value of x rounded to single precision (as a C++ `0.6f` is), so that products of such
-- numbers match the fixtures bit for bit.
function paper.f32(x)
  return (string.unpack("f", string.pack("f", x)))
end

-- From the viewers' side and above, spread left and right so the shadows read in every module.
function paper.add_lights()
  local f32 = paper.f32
  local white = {f32(0.32), f32(0.32), f32(0.30)}
  local dim = {f32(0.6) * white[1], f32(0.6) * white[2], f32(0.6) * white[3]}
  return {
    px.directional{direction = {0.3, -0.3, -1.0}, color = white},
    px.directional{direction = {-0.3, -0.3, -1.0}, color = white},
    px.directional{direction = {0.8, -0.15, -0.6}, color = dim},
    px.directional{direction = {-0.8, -0.15, -0.6}, color = dim},
  }
end

-- The stage of the animated library scenes (sentinel, walker): a stone pedestal on a polished
-- floor under the paper's lights, and the world box around them.
function paper.pedestal_stage()
  local stone = px.diffuse{name = "pedestal", color = {0.7, 0.68, 0.62}}
  px.box{size = {3.2, 0.4, 1.6}, material = stone, transform = px.translate(0, 0.2, 0)}
  local floor = px.mirror{name = "polished_floor", reflectance = {0.6, 0.6, 0.65}}
  px.grid{width = 4.0, height = 2.0, material = floor, transform = px.rotate_x(-math.pi / 2)}
  paper.add_lights()
  px.ambient({0.06, 0.06, 0.06})
  px.background({0.04, 0.05, 0.07})
  px.world_box{min = {-2.0, 0.0, -1.0}, max = {2.0, 2.25, 1.0}}
  px.max_depth(5)
end

-- Adds an object made by `shape` (px.box, px.grid, ...) with `options`, placed by
-- parent * local_transform: the scene's own frame composed with the object's placement.
function paper.placer(parent)
  return function(shape, options, local_transform)
    options.transform = parent * local_transform
    return shape(options)
  end
end

return paper
