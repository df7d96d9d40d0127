// The page served at "/" when no web viewer is installed: a job list (upload, progress,
// downloads) in plain HTML + fetch, so the server is usable from a browser on its own.
#pragma once

#include <string>

namespace glam::server {

const std::string& BuiltInIndexHtml();

}  // namespace glam::server
