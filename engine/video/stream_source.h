// A live video stream as a FrameSource: a drone's or ground station's RTSP/RTMP/SRT/UDP feed,
// a TCP or HTTP stream, or standard input ("-"), decoded by FFmpeg (VideoDecoder).
//
// Why a reader thread of its own: a live sender does not wait. Mapping runs at its own pace
// (bundle adjustments make it uneven, and at 720p it can be slower than 30 fps), while the
// network keeps delivering; unread UDP datagrams are lost mid-frame (the decoder then smears
// grey over the damaged frames) and RTSP/RTMP servers drop a client that lags too far. So one
// thread only reads and decodes, into a buffer of FrameSourceOptions::stream_buffer_s seconds;
// when mapping falls behind and the buffer is full, whole frames are dropped (the oldest
// buffered one: the map keeps following the newest frames), never parts of frames. Frames are
// numbered by their presentation time (index = t x fps from the first frame), so a frame
// dropped here or lost in transit is a gap in the trajectory, as with --stride, and t = index /
// fps stays the stream's time. Pipes and HTTP files wait for the reader instead (kWait).
//
// What a stream cannot do, and what follows: it has no frame count (FrameSourceInfo::frame_count
// = -1: progress without a total) and cannot seek (a run resumed on a stream maps what arrives
// from then on, numbered after the frames it mapped before), and its end is decided here: the sender closes it, no frame arrives for
// stream_stall_timeout_s, or FrameSourceOptions::end_stream is cancelled (the user stops it);
// each of these ends the input normally, so the map of what arrived is finished and written.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <exception>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "engine/video/frame_source.h"
#include "engine/video/video_decoder.h"

namespace glam {

// The URL FFmpeg is given for `input` ("-" is standard input, pipe:0).
std::string StreamUrl(const std::string& input);

// `url` with the user information of its authority (user:password@) replaced by "***@" and
// the values of query parameters named passphrase, password, pass, pwd, token, key or secret
// by "***": how logs, reports and the job JSON show a stream (camera URLs often carry
// credentials). An empty user part (udp://@:5004, FFmpeg's "any address") stays.
std::string RedactStreamUrl(const std::string& url);

// Whether frames are dropped when mapping falls behind `input` (kAuto: for the live protocols
// rtsp, rtsps, rtmp, rtmps, srt, udp and rtp).
bool StreamDropsFrames(const std::string& input, FrameSourceOptions::StreamDrop policy);

class StreamSource : public FrameSource {
 public:
  // Opens the stream and decodes its first frame (waiting up to stream_open_timeout_s; for a
  // listening URL such as tcp://0.0.0.0:5000?listen=1 that includes the sender connecting),
  // then starts the reader thread. Throws InputError when it does not open, has no video, or
  // delivers no frame in time.
  StreamSource(const std::string& input, const FrameSourceOptions& options);
  // Stops the reader (an I/O wait is interrupted at once) and joins it.
  ~StreamSource() override;
  StreamSource(const StreamSource&) = delete;
  StreamSource& operator=(const StreamSource&) = delete;

  // Waits for the next buffered frame; nullopt once the stream ended and the buffer is empty.
  // Rethrows an error of the reader (a pixel format that cannot be converted).
  std::optional<Frame> Next() override;
  const FrameSourceInfo& info() const override { return info_; }
  // A stream cannot seek. Before the first Next(), SeekTo(n > 0) numbers its frames from n on
  // (the first one received gets index n: a resumed run continues after what it mapped);
  // SeekTo(where it is) does nothing; anything else is an InputError.
  void SeekTo(int64_t index) override;
  int64_t frames_delivered() const override;
  bool ended_early() const override { return false; }
  int64_t frames_dropped() const override;
  // Stops the reader (an I/O wait is interrupted at once); Next() returns nullopt from now on.
  void Abort() override;

  bool drops_frames() const { return drop_; }
  // A jump ahead in the stream's timestamps up to this long is frames lost in transit (they
  // become a gap in the frame numbers); longer, or back in time, is a discontinuity (a sender
  // that restarted its clock), after which numbering goes on from the last frame.
  static constexpr double kMaxTimestampGapS = 10.0;
  // Frames the buffer holds at most.
  std::size_t buffer_capacity() const { return capacity_; }

 private:
  using Clock = std::chrono::steady_clock;

  void ReadLoop();
  // The number of the frame just grabbed: by its presentation time (index = t x fps), so that
  // frames lost in transit leave a gap and t = index / fps stays the stream's time; one more
  // than the last number when the timestamps are missing or discontinuous. Reader thread (and
  // the constructor) only.
  int64_t NumberFrame();
  // FFmpeg's interrupt callback: closing, ended by the user, or waiting too long.
  bool ShouldInterrupt() const;
  // The frame the decoder just grabbed, with stream number `number`, at processing size.
  Frame GrabbedFrame(int64_t number);
  // Appends a decoded frame (its index and time as SeekTo() asked), dropping the oldest or
  // waiting when the buffer is full; false when the source is closing.
  bool Push(Frame frame);

  // A pipe input's descriptor ("-", pipe:N) made non-blocking; its flags are restored when the
  // source is destroyed (after the reader is joined), or when the constructor throws.
  struct NonBlockingPipe {
    int fd = -1;
    int flags = -1;  // before
    NonBlockingPipe() = default;
    NonBlockingPipe(const NonBlockingPipe&) = delete;
    NonBlockingPipe& operator=(const NonBlockingPipe&) = delete;
    ~NonBlockingPipe();
  };

  std::string url_;    // what FFmpeg opens
  std::string input_;  // how messages name it (RedactStreamUrl)
  FrameSourceOptions options_;
  NonBlockingPipe pipe_;
  FrameSourceInfo info_;
  bool drop_ = false;
  std::size_t capacity_ = 2;
  std::unique_ptr<VideoDecoder> decoder_;

  std::atomic<bool> closing_{false};
  std::atomic<bool> opened_{false};
  mutable std::atomic<bool> timed_out_{false};    // an I/O wait hit its time limit
  mutable std::atomic<bool> interrupted_{false};  // ShouldInterrupt() said yes once
  // Start of the current I/O wait (steady clock ticks): the open, or the current Grab().
  std::atomic<Clock::rep> wait_start_{0};

  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<Frame> buffer_;
  bool finished_ = false;  // the reader has ended
  std::exception_ptr error_;
  int64_t dropped_ = 0;
  int64_t delivered_ = 0;
  int64_t last_number_ = -1;  // NumberFrame()'s state (reader thread)
  int64_t time_anchor_ = 0;
  int64_t next_wanted_ = 0;   // the next number --stride delivers (reader thread)
  int64_t next_index_ = 0;    // index of the next frame Next() returns, if nothing is dropped
  int64_t index_offset_ = 0;  // added to the stream's own frame numbers (SeekTo before Next)
  std::thread reader_;
};

}  // namespace glam
