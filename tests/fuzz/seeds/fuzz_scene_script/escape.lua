px.texture{path = "../x.png"}
require "lib.paper"
setmetatable({}, {__gc = function() px.box{} end})
