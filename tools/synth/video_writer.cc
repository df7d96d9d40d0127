#include "tools/synth/video_writer.h"

#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <sstream>
#include <string>

#include <fmt/format.h>

#include "engine/core/error.h"
#include "engine/core/logging.h"

namespace glam::synth {

namespace {

bool HasFfmpeg() {
  const char* path = std::getenv("PATH");
  if (path == nullptr) return false;
  std::stringstream dirs(path);
  std::string dir;
  while (std::getline(dirs, dir, ':')) {
    if (!dir.empty() && ::access((std::filesystem::path(dir) / "ffmpeg").c_str(), X_OK) == 0) return true;
  }
  return false;
}

std::string ShellQuote(const std::string& s) {
  std::string out = "'";
  for (char c : s) {
    if (c == '\'') {
      out += "'\\''";
    } else {
      out += c;
    }
  }
  return out + "'";
}

}  // namespace

VideoWriter::VideoWriter(const std::filesystem::path& path, int width, int height, double fps, int crf)
    : path_(path), width_(width), height_(height) {
  if (HasFfmpeg()) {
    const std::string command = fmt::format(
        "ffmpeg -hide_banner -loglevel error -y -f rawvideo -pix_fmt bgr24 -s {}x{} -r {} -i - "
        "-c:v libx264 -preset veryfast -crf {} -pix_fmt yuv420p -threads 2 -movflags +faststart {}",
        width, height, fps, crf, ShellQuote(path.string()));
    pipe_ = ::popen(command.c_str(), "w");
    if (pipe_ == nullptr) throw EnvironmentError("cannot start ffmpeg for " + path.string());
    return;
  }
  GLAM_LOG_WARN("synth: no ffmpeg binary on PATH, using cv::VideoWriter (avc1)");
  fallback_.open(path.string(), cv::CAP_FFMPEG, cv::VideoWriter::fourcc('a', 'v', 'c', '1'), fps,
                 cv::Size(width, height));
  if (!fallback_.isOpened()) throw EnvironmentError("cannot open an H.264 writer for " + path.string());
}

VideoWriter::~VideoWriter() {
  if (pipe_ != nullptr) ::pclose(pipe_);
}

void VideoWriter::Write(const cv::Mat& bgr) {
  GLAM_CHECK(bgr.type() == CV_8UC3 && bgr.cols == width_ && bgr.rows == height_, "bad frame");
  if (pipe_ == nullptr) {
    fallback_.write(bgr);
    return;
  }
  const cv::Mat frame = bgr.isContinuous() ? bgr : bgr.clone();
  const std::size_t bytes = frame.total() * frame.elemSize();
  if (std::fwrite(frame.data, 1, bytes, pipe_) != bytes) {
    throw EnvironmentError("ffmpeg stopped accepting frames for " + path_.string());
  }
}

void VideoWriter::Close() {
  if (pipe_ == nullptr) {
    fallback_.release();
    return;
  }
  const int status = ::pclose(pipe_);
  pipe_ = nullptr;
  if (status == -1 || !WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    throw EnvironmentError("ffmpeg failed writing " + path_.string());
  }
}

}  // namespace glam::synth
