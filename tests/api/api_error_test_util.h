// What an api::ApiError thrown by a service call says, for asserting documented statuses and
// codes without a try block in every test.
#pragma once

#include <functional>
#include <string>

#include "api/api_error.h"

namespace glam::api::testing {

// The status of the ApiError `call` throws; 0 when it throws none.
inline int StatusOf(const std::function<void()>& call) {
  try {
    call();
  } catch (const ApiError& e) {
    return e.status();
  }
  return 0;
}

// The code of the ApiError `call` throws; empty when it throws none.
inline std::string CodeOf(const std::function<void()>& call) {
  try {
    call();
  } catch (const ApiError& e) {
    return e.code();
  }
  return "";
}

}  // namespace glam::api::testing
