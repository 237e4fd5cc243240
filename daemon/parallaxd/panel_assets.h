#pragma once
// The control panel's page (daemon/parallaxd/panel/), compiled into the program by
// embed_panel_assets.cmake: the panel serves these bytes and nothing from the file system.

#include <string_view>
#include <vector>

namespace parallax::daemon {

struct PanelAsset {
  std::string_view path;  // "/index.html", "/panel.js", "/panel.css", "/favicon.svg"
  std::string_view contentType;
  std::string_view body;
};

const std::vector<PanelAsset>& panelAssets();
// nullptr when `path` is not one of them (exact match: no normalisation, no folders).
const PanelAsset* findPanelAsset(std::string_view path);

}  // namespace parallax::daemon
