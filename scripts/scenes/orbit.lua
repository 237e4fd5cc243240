-- An animated demo: a mirror sphere and a glass ball orbit a gold torus above a checkered
-- floor, and the key light turns slowly. Parameters change the speed and the orbit radius
-- while it plays (render --set speed=0.5, the daemon's control socket).
local paper = require "lib.paper"

local speed = px.param{name = "speed", default = 0.25, min = 0, max = 2,
                       description = "orbit turns per second"}
px.param{name = "radius", default = 0.6, min = 0.3, max = 0.8, description = "orbit radius (world units)"}

px.name("orbit")

-- An 8 × 8 checkerboard texture built in the script.
local pixels = {}
for row = 0, 7 do
  for column = 0, 7 do
    local v = ((row + column) % 2 == 0) and 0.8 or 0.15
    pixels[#pixels + 1] = v
    pixels[#pixels + 1] = v
    pixels[#pixels + 1] = v
  end
end
local checker = px.image{width = 8, height = 8, pixels = pixels}

local floor = px.diffuse{name = "checker_floor", color = {1, 1, 1}, texture = checker}
local gold = px.phong{name = "gold", color = {0.8, 0.6, 0.2}, specular = {0.6, 0.6, 0.5}, shininess = 60}
local chrome = px.mirror{name = "chrome", reflectance = {0.9, 0.9, 0.9}}
local glass = px.glass{name = "glass", ior = 1.5}
local glow = px.emissive{name = "glow", color = {2.0, 1.2, 0.4}}

local wall = px.diffuse{name = "wall", color = {0.45, 0.5, 0.65}}

-- The stage is tilted toward the viewers (who sit at the screen centre's height) so the floor
-- is not seen edge-on; `stage` carries every object.
local stage = px.translate(0, 0.2, 0) * px.rotate_x(0.35)
px.grid{width = 2.4, height = 1.6, nx = 8, ny = 8, material = floor, name = "floor",
        transform = stage * px.rotate_x(-math.pi / 2)}
px.grid{width = 2.4, height = 1.2, nx = 2, ny = 2, material = wall, name = "back_wall",
        transform = stage * px.translate(0, 0.6, -0.8)}
local torus = px.torus{major = 0.32, minor = 0.1, material = gold, name = "torus"}
local mirror_ball = px.sphere{radius = 0.2, slices = 24, stacks = 12, material = chrome, name = "mirror_ball"}
local glass_ball = px.sphere{radius = 0.16, slices = 24, stacks = 12, material = glass, name = "glass_ball"}
local beacon = px.box{size = {0.08, 0.08, 0.08}, material = glow, name = "beacon"}

local lights = paper.add_lights()
px.ambient({0.05, 0.05, 0.05})
px.background({0.03, 0.03, 0.05})
-- The orbit's widest extent, so B_W (and the image's scale) does not change as it moves.
px.world_box{min = {-1.2, -0.1, -0.75}, max = {1.2, 1.25, 0.75}}
px.max_depth(5)

function update(t, dt)
  local angle = 2 * math.pi * params.speed * t
  local r = params.radius
  px.set_transform(mirror_ball, stage * px.translate(r * math.cos(angle), 0.25, r * math.sin(angle)))
  px.set_transform(glass_ball, stage * px.translate(-r * math.cos(angle), 0.45, -r * math.sin(angle)))
  px.set_transform(torus, stage * px.translate(0, 0.4, 0) * px.rotate_y(angle * 0.5) * px.rotate_x(0.4))
  px.set_transform(beacon, stage * px.translate(0, 0.8 + 0.1 * math.sin(3 * angle), 0) * px.rotate_y(angle))
  px.set_light(lights[1], {direction = {0.3 * math.cos(angle * 0.25), -0.3, -1.0}})
  local pulse = 0.75 + 0.25 * math.sin(2 * angle)
  px.set_material(glow, {emission = {2.0 * pulse, 1.2 * pulse, 0.4 * pulse}})
end
