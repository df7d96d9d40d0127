// Failures of a service call that a client caused or can act on, with the HTTP status and a
// stable machine-readable code (the REST layer sends {"error": {"code", "message"}}). The
// service speaks HTTP status numbers because they are part of the documented API contract
// (api/openapi.yaml), not because it knows about HTTP.
#pragma once

#include <stdexcept>
#include <string>

namespace glam::api {

class ApiError : public std::runtime_error {
 public:
  ApiError(int status, std::string code, const std::string& message)
      : std::runtime_error(message), status_(status), code_(std::move(code)) {}
  int status() const { return status_; }
  const std::string& code() const { return code_; }

 private:
  int status_;
  std::string code_;
};

}  // namespace glam::api
