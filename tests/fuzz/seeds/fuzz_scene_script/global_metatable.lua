function update(t) end
setmetatable(_G, {__index = function() error("boom") end, __newindex = function() while true do end end})
local m = px.diffuse{}
px.box{material = m}
