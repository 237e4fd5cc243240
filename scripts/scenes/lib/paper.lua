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

-- Adds an object made by `shape` (px.box, px.grid, ...) with `options`, placed by
-- parent * local_transform: the scene's own frame composed with the object's placement.
function paper.placer(parent)
  return function(shape, options, local_transform)
    options.transform = parent * local_transform
    return shape(options)
  end
end

return paper
