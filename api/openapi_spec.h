// api/openapi.yaml, embedded at build time so that `glam serve` can serve
// /api/v1/openapi.yaml without depending on where the source tree or an install put files.
#pragma once

#include <string_view>

namespace glam::api {

std::string_view OpenApiYaml();

}  // namespace glam::api
