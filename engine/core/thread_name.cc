#include "engine/core/thread_name.h"

#include <pthread.h>

namespace glam {

void NameCurrentThread(std::string_view name) {
  const std::string cut(name.substr(0, kMaxThreadNameLength));
  pthread_setname_np(pthread_self(), cut.c_str());
}

std::string CurrentThreadName() {
  char buffer[kMaxThreadNameLength + 1] = {};
  if (pthread_getname_np(pthread_self(), buffer, sizeof(buffer)) != 0) return {};
  return buffer;
}

}  // namespace glam
