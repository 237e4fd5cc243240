local m = px.phong{color = {0.5, 0.4, 0.3}, specular = {0.2, 0.2, 0.2}, shininess = 8}
local t = px.image{width = 2, height = 2, pixels = {1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 1, 1}}
local d = px.diffuse{texture = t}
local o = px.mesh{positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, triangles = {{1, 2, 3}},
                  uvs = {{0, 0}, {1, 0}, {0, 1}}, colors = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, material = d}
local c = px.instance(o, px.rotate({1, 1, 0}, 0.5) * px.scale(2, 1, 1))
px.cylinder{radius = 0.2, height = 0.5, material = m}
px.cone{radius = 0.2, height = 0.5, material = m}
px.plane{width = 3, height = 2, material = px.mirror{}, transform = px.rotate_z(0.1)}
local p = px.point{position = {0, 2, 1}, color = {1, 1, 1}}
local k = px.param{name = "k", default = 1, min = 0, max = 2, description = "brightness"}
function update(t, dt)
  px.set_light(p, {position = {math.sin(t), 2, 1}, color = {params.k, params.k, params.k}})
  px.set_transform(c, px.translate(t, 0, 0))
  px.set_material(m, {color = {t % 1, 0.5, 0.5}})
  px.background({0, 0, t % 1})
end
