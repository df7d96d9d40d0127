#include "engine/core/thread_name.h"

#include <fstream>
#include <string>
#include <thread>

#include <sys/syscall.h>
#include <unistd.h>

#include <gtest/gtest.h>

namespace glam {
namespace {

// What `top -H` and the scale benchmark read: /proc/self/task/<tid>/comm.
std::string CommOfCallingThread() {
  const long tid = syscall(SYS_gettid);
  std::ifstream in("/proc/self/task/" + std::to_string(tid) + "/comm");
  std::string comm;
  std::getline(in, comm);
  return comm;
}

TEST(ThreadName, TheNameIsWhatTheSystemShowsForTheThread) {
  std::string seen, read_back;
  std::thread t([&] {
    NameCurrentThread("glam-test");
    seen = CommOfCallingThread();
    read_back = CurrentThreadName();
  });
  t.join();
  EXPECT_EQ(seen, "glam-test");
  EXPECT_EQ(read_back, "glam-test");
}

TEST(ThreadName, ALongNameIsCutToFifteenCharactersInsteadOfBeingRefused) {
  std::string seen;
  std::thread t([&] {
    NameCurrentThread("glam-a-very-long-stage-name");
    seen = CommOfCallingThread();
  });
  t.join();
  EXPECT_EQ(seen, std::string("glam-a-very-long-stage-name").substr(0, kMaxThreadNameLength));
}

TEST(ThreadName, NamingAnotherThreadLeavesTheCallerAlone) {
  const std::string before = CurrentThreadName();
  std::thread t([] { NameCurrentThread("glam-other"); });
  t.join();
  EXPECT_EQ(CurrentThreadName(), before);
}

}  // namespace
}  // namespace glam
