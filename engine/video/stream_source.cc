#include "engine/video/stream_source.h"

#include <fcntl.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>

#include "engine/core/error.h"
#include "engine/core/logging.h"
#include "engine/core/thread_name.h"

namespace glam {
namespace {

bool HasOption(const std::vector<std::pair<std::string, std::string>>& options, const std::string& key) {
  return std::any_of(options.begin(), options.end(), [&](const auto& o) { return o.first == key; });
}

// The descriptor FFmpeg's pipe protocol reads for `url` ("pipe:N", "pipe:" = 0), or -1.
int PipeDescriptor(const std::string& url) {
  if (url.rfind("pipe:", 0) != 0) return -1;
  const std::string number = url.substr(5);
  if (number.empty()) return 0;
  char* end = nullptr;
  const long fd = std::strtol(number.c_str(), &end, 10);
  return end != nullptr && *end == '\0' && fd >= 0 ? static_cast<int>(fd) : -1;
}

}  // namespace

std::string StreamUrl(const std::string& input) { return input == "-" ? "pipe:0" : input; }

std::string RedactStreamUrl(const std::string& url) {
  const std::size_t scheme_end = url.find("://");
  if (scheme_end == std::string::npos) return url;
  const std::size_t authority = scheme_end + 3;
  const std::size_t authority_end = url.find_first_of("/?#", authority);
  std::string out = url;
  // user:password@host (an empty user part, udp://@:5004, is FFmpeg's "any address").
  const std::size_t at = url.rfind('@', authority_end);
  if (at != std::string::npos && at > authority) out = url.substr(0, authority) + "***" + url.substr(at);
  // Query parameters that carry secrets (SRT's passphrase, tokens of HTTP and RTMP servers).
  const std::size_t query = out.find('?');
  if (query == std::string::npos) return out;
  std::string redacted = out.substr(0, query + 1);
  std::size_t begin = query + 1;
  while (begin <= out.size()) {
    std::size_t end = out.find_first_of("&#", begin);
    if (end == std::string::npos) end = out.size();
    std::string pair = out.substr(begin, end - begin);
    const std::size_t eq = pair.find('=');
    std::string key = pair.substr(0, eq);
    for (char& c : key) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    if (eq != std::string::npos) {
      for (const char* secret : {"passphrase", "password", "pass", "pwd", "token", "key", "secret"}) {
        if (key == secret) pair = pair.substr(0, eq + 1) + "***";
      }
    }
    redacted += pair;
    if (end == out.size()) break;
    if (out[end] == '#') {
      redacted += out.substr(end);
      break;
    }
    redacted += '&';
    begin = end + 1;
  }
  return redacted;
}

bool StreamDropsFrames(const std::string& input, FrameSourceOptions::StreamDrop policy) {
  if (policy != FrameSourceOptions::StreamDrop::kAuto) return policy == FrameSourceOptions::StreamDrop::kDrop;
  const std::string scheme = UrlScheme(input);
  for (const char* live : {"rtsp", "rtsps", "rtmp", "rtmps", "srt", "udp", "rtp"}) {
    if (scheme == live) return true;
  }
  return false;
}

StreamSource::StreamSource(const std::string& input, const FrameSourceOptions& options)
    : url_(input), input_(RedactStreamUrl(input)), options_(options) {
  options_.Check();
  drop_ = StreamDropsFrames(url_, options_.stream_drop);

  VideoDecoderOptions decoder_options;
  decoder_options.format_options = options_.stream_options;
  // RTSP over UDP loses packets on any busy link, and a lost packet damages a whole frame.
  if ((UrlScheme(input) == "rtsp" || UrlScheme(input) == "rtsps") &&
      !HasOption(decoder_options.format_options, "rtsp_transport")) {
    decoder_options.format_options.emplace_back("rtsp_transport", "tcp");
  }
  // FFmpeg probes a stream for up to 5 s (analyzeduration) before the first frame is read; a
  // live sender keeps sending meanwhile, and that backlog then arrives at once, more than the
  // frame buffer holds. An RTMP feed (FLV) took the whole 5 s: 86 of its first 182 frames were
  // dropped; with 1 s it opened in 1.1 s and none were (docs/benchmarks.md, "Live stream").
  // Joining an MPEG-TS feed mid-GOP still waits for the next keyframe, as before.
  if (!HasOption(decoder_options.format_options, "analyzeduration")) {
    decoder_options.format_options.emplace_back("analyzeduration", "1000000");
  }
  decoder_options.interrupt = [this] { return ShouldInterrupt(); };
  decoder_options.display_name = input_;
  // FFmpeg's pipe protocol blocks in read(2), where no interrupt reaches it (an idle pipe would
  // hold the reader, and the job, forever); non-blocking, its reads poll the interrupt every
  // millisecond. The flags are restored when the source closes (stdin may be shared).
  if (const int fd = PipeDescriptor(StreamUrl(url_)); fd >= 0) {
    const int flags = fcntl(fd, F_GETFL);
    if (flags < 0 || fcntl(fd, F_SETFL, flags | O_NONBLOCK) < 0) {
      throw InputError(fmt::format("stream '{}': descriptor {} is not open", input_, fd));
    }
    pipe_.fd = fd;
    pipe_.flags = flags;
  }
  wait_start_.store(Clock::now().time_since_epoch().count());
  GLAM_LOG_INFO("opening stream '{}' (waiting up to {:.3g} s)", input_, options_.stream_open_timeout_s);
  try {
    decoder_ = std::make_unique<VideoDecoder>(StreamUrl(url_), decoder_options);
  } catch (const InputError& e) {
    if (options_.end_stream.IsCancelled()) {
      throw InputError(fmt::format("stream '{}' was ended before it opened", input_));
    }
    throw InputError(fmt::format("cannot open stream '{}': {} (nothing within {:.3g} s, or not a "
                                 "video stream FFmpeg can read)",
                                 input_, e.what(), options_.stream_open_timeout_s));
  }
  if (!decoder_->Grab()) {
    throw InputError(fmt::format("stream '{}' delivered no decodable frame within {:.3g} s", input_,
                                 options_.stream_open_timeout_s));
  }
  opened_.store(true);

  info_.fps = decoder_->fps();
  if (!(info_.fps > 0.0) || !std::isfinite(info_.fps) || info_.fps > 1000.0) {
    GLAM_LOG_WARN("stream '{}' reports no usable frame rate ({}); assuming 30 fps", input_, info_.fps);
    info_.fps = 30.0;
  }
  info_.frame_count = -1;
  info_.original_size = decoder_->display_size();
  info_.processing_size = ProcessingSize(info_.original_size, options_.max_image_size);
  info_.scale = static_cast<double>(info_.processing_size.width) / info_.original_size.width;
  const double frame_bytes = 3.0 * info_.processing_size.area();  // 8-bit BGR
  const double by_memory = std::floor(options_.stream_buffer_max_mb * 1048576.0 / frame_bytes);
  capacity_ = static_cast<std::size_t>(
      std::max(2.0, std::min(std::round(options_.stream_buffer_s * info_.fps), by_memory)));

  const int64_t first = NumberFrame();
  next_wanted_ = first + options_.stride;
  Push(GrabbedFrame(first));  // a format we cannot convert fails here, before the reader starts
  GLAM_LOG_INFO("stream '{}': {}x{} @ {:.3f} fps, processing {}x{}; buffer {} frames, {} when mapping "
                "falls behind",
                input_, info_.original_size.width, info_.original_size.height, info_.fps,
                info_.processing_size.width, info_.processing_size.height, capacity_,
                drop_ ? "frames are dropped" : "reading waits");
  reader_ = std::thread([this] {
    NameCurrentThread("glam-stream");
    ReadLoop();
  });
}

StreamSource::~StreamSource() {
  Abort();
  if (reader_.joinable()) reader_.join();
}

void StreamSource::Abort() {
  {
    // Under the mutex: a thread between checking its wait's condition and blocking must not
    // miss the notification.
    std::lock_guard<std::mutex> lock(mutex_);
    closing_.store(true);
  }
  changed_.notify_all();
}

StreamSource::NonBlockingPipe::~NonBlockingPipe() {
  if (fd >= 0 && flags >= 0) fcntl(fd, F_SETFL, flags);
}

bool StreamSource::ShouldInterrupt() const {
  if (closing_.load() || options_.end_stream.IsCancelled()) {
    interrupted_.store(true);
    return true;
  }
  const double limit = opened_.load() ? options_.stream_stall_timeout_s : options_.stream_open_timeout_s;
  const Clock::duration waited = Clock::now().time_since_epoch() - Clock::duration(wait_start_.load());
  if (std::chrono::duration<double>(waited).count() <= limit) return false;
  timed_out_.store(true);
  interrupted_.store(true);
  return true;
}

Frame StreamSource::GrabbedFrame(int64_t number) {
  Frame frame;
  frame.index = number;  // in the stream; Push() numbers it as SeekTo() asked
  frame.original_size = decoder_->display_size();
  decoder_->Retrieve(info_.processing_size, &frame.bgr);
  return frame;
}

bool StreamSource::Push(Frame frame) {
  std::unique_lock<std::mutex> lock(mutex_);
  frame.index += index_offset_;
  frame.timestamp_s = static_cast<double>(frame.index) / info_.fps;
  if (buffer_.size() >= capacity_) {
    if (drop_) {
      if (dropped_ == 0) {
        GLAM_LOG_WARN("stream '{}': mapping is slower than the stream; frames are dropped from now "
                      "on when the buffer of {} frames is full (report.json frames_dropped)",
                      input_, capacity_);
      }
      buffer_.pop_front();
      ++dropped_;
    } else {
      changed_.wait(lock, [this] { return buffer_.size() < capacity_ || closing_.load(); });
    }
  }
  if (closing_.load()) return false;
  buffer_.push_back(std::move(frame));
  lock.unlock();
  changed_.notify_all();
  return true;
}

void StreamSource::ReadLoop() {
  std::string reason = "the sender ended it";
  try {
    // The end request is checked here too: the demuxer reads ahead while the stream opens
    // (seconds of it), and frames decoded from what it holds need no I/O, where FFmpeg would
    // ask the interrupt callback.
    while (!closing_.load() && !options_.end_stream.IsCancelled()) {
      wait_start_.store(Clock::now().time_since_epoch().count());
      // After an interrupt the decoder only flushes what it holds, and the demuxer may hand it
      // the packet it was reading when the read was cut off: such a frame can be damaged (on
      // the lawnmower test clip a stream ended at frame 293 came out at 0.35 m ATE instead of 0.09 m), so
      // nothing after an interrupt is delivered.
      if (!decoder_->Grab() || interrupted_.load()) {
        if (options_.end_stream.IsCancelled()) {
          reason = "ended on request";
        } else if (timed_out_.load()) {
          reason = fmt::format("nothing received for {:.3g} s", options_.stream_stall_timeout_s);
        }
        break;
      }
      const int64_t index = NumberFrame();
      if (index < next_wanted_) continue;  // --stride
      next_wanted_ = index + options_.stride;
      if (!Push(GrabbedFrame(index))) break;
    }
  } catch (...) {
    std::lock_guard<std::mutex> lock(mutex_);
    error_ = std::current_exception();
  }
  if (options_.end_stream.IsCancelled()) reason = "ended on request";
  if (!closing_.load()) {
    GLAM_LOG_INFO("stream '{}' ended after frame {} ({})", input_, last_number_, reason);
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    finished_ = true;
  }
  changed_.notify_all();
}

int64_t StreamSource::NumberFrame() {
  // Up to this many frames of a jump ahead in the timestamps are frames lost in transit; more
  // is a sender that restarted its clock.
  const int64_t max_gap = static_cast<int64_t>(std::ceil(kMaxTimestampGapS * info_.fps));
  int64_t number = last_number_ + 1;
  if (const std::optional<double> t = decoder_->seconds_since_first()) {
    const int64_t by_time = std::llround(*t * info_.fps);
    if (by_time + time_anchor_ > last_number_ && by_time + time_anchor_ - last_number_ <= max_gap) {
      number = by_time + time_anchor_;
    } else {
      time_anchor_ = number - by_time;  // a discontinuity: go on from the last number
    }
  }
  last_number_ = number;
  return number;
}

std::optional<Frame> StreamSource::Next() {
  std::unique_lock<std::mutex> lock(mutex_);
  changed_.wait(lock, [this] { return !buffer_.empty() || finished_ || closing_.load(); });
  if (closing_.load()) return std::nullopt;  // Abort()
  if (buffer_.empty()) {
    if (error_) std::rethrow_exception(error_);
    return std::nullopt;
  }
  Frame frame = std::move(buffer_.front());
  buffer_.pop_front();
  ++delivered_;
  next_index_ = frame.index + options_.stride;
  lock.unlock();
  changed_.notify_all();
  return frame;
}

void StreamSource::SeekTo(int64_t index) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (index == next_index_) return;
  if (delivered_ == 0 && index > next_index_) {
    // Nothing delivered yet: number the stream's frames from `index` on (a resumed run goes on
    // after the frames it has mapped), the buffered ones included.
    const int64_t shift = index - next_index_;
    for (Frame& frame : buffer_) {
      frame.index += shift;
      frame.timestamp_s = static_cast<double>(frame.index) / info_.fps;
    }
    index_offset_ += shift;
    next_index_ = index;
    return;
  }
  throw InputError(fmt::format("'{}' is a live stream: it cannot seek to frame {} (next is {})", input_,
                               index, next_index_));
}

int64_t StreamSource::frames_delivered() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return delivered_;
}

int64_t StreamSource::frames_dropped() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return dropped_;
}

}  // namespace glam
