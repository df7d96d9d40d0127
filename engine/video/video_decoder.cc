#include "engine/video/video_decoder.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <mutex>

#include <opencv2/core.hpp>

extern "C" {
#include <libavcodec/avcodec.h>
#include <libavformat/avformat.h>
#include <libavutil/display.h>
#include <libavutil/log.h>
#include <libavutil/pixdesc.h>
#include <libswscale/swscale.h>
}

#include "engine/core/error.h"
#include "engine/core/logging.h"
#include "engine/core/options.h"

namespace glam {
namespace {

// libav's own messages (corrupt packets, missing references) go to our log at debug level:
// a damaged file is reported once, by the caller, not as pages of decoder chatter on stderr.
void LibavLogCallback(void* avcl, int level, const char* format, va_list args) {
  if (level > AV_LOG_WARNING) return;
  thread_local int print_prefix = 1;
  char line[1024];
  av_log_format_line2(avcl, level, format, args, line, sizeof(line), &print_prefix);
  std::string text(line);
  while (!text.empty() && (text.back() == '\n' || text.back() == '\r')) text.pop_back();
  if (!text.empty()) GLAM_LOG_DEBUG("libav: {}", text);
}

void InstallLibavLogCallback() {
  static std::once_flag once;
  std::call_once(once, [] { av_log_set_callback(&LibavLogCallback); });
}

std::string AvErrorText(int code) {
  char text[AV_ERROR_MAX_STRING_SIZE] = {0};
  av_strerror(code, text, sizeof(text));
  return text;
}

// The "J" pixel formats are the plain ones with full-range samples (JPEG / Motion-JPEG).
AVPixelFormat WithoutJpegRange(AVPixelFormat format, bool* full_range) {
  switch (format) {
    case AV_PIX_FMT_YUVJ420P: *full_range = true; return AV_PIX_FMT_YUV420P;
    case AV_PIX_FMT_YUVJ422P: *full_range = true; return AV_PIX_FMT_YUV422P;
    case AV_PIX_FMT_YUVJ444P: *full_range = true; return AV_PIX_FMT_YUV444P;
    case AV_PIX_FMT_YUVJ440P: *full_range = true; return AV_PIX_FMT_YUV440P;
    case AV_PIX_FMT_YUVJ411P: *full_range = true; return AV_PIX_FMT_YUV411P;
    default: return format;
  }
}

// swscale's name for the stream's YUV -> RGB matrix (HD footage is BT.709).
int SwsColorspace(AVColorSpace space) {
  switch (space) {
    case AVCOL_SPC_BT709: return SWS_CS_ITU709;
    case AVCOL_SPC_FCC: return SWS_CS_FCC;
    case AVCOL_SPC_SMPTE240M: return SWS_CS_SMPTE240M;
    case AVCOL_SPC_BT2020_NCL:
    case AVCOL_SPC_BT2020_CL: return SWS_CS_BT2020;
    case AVCOL_SPC_BT470BG:
    case AVCOL_SPC_SMPTE170M: return SWS_CS_ITU601;
    default: return SWS_CS_DEFAULT;
  }
}

struct FormatDeleter {
  void operator()(AVFormatContext* c) const { avformat_close_input(&c); }
};
struct CodecDeleter {
  void operator()(AVCodecContext* c) const { avcodec_free_context(&c); }
};
struct FrameDeleter {
  void operator()(AVFrame* f) const { av_frame_free(&f); }
};
struct PacketDeleter {
  void operator()(AVPacket* p) const { av_packet_free(&p); }
};
struct SwsDeleter {
  void operator()(SwsContext* s) const { sws_freeContext(s); }
};

}  // namespace

void VideoDecoderOptions::Check() const {
  CheckGreaterEqual("VideoDecoderOptions.threads", threads, 0);
}

struct VideoDecoder::Impl {
  std::filesystem::path path;
  std::string name;  // how messages name the input (VideoDecoderOptions::display_name)
  int threads = 0;
  std::vector<std::pair<std::string, std::string>> format_options;
  std::function<bool()> interrupt;
  std::unique_ptr<AVFormatContext, FormatDeleter> format;
  std::unique_ptr<AVCodecContext, CodecDeleter> codec;
  std::unique_ptr<AVFrame, FrameDeleter> frame{av_frame_alloc()};
  std::unique_ptr<AVPacket, PacketDeleter> packet{av_packet_alloc()};
  std::unique_ptr<SwsContext, SwsDeleter> sws;
  AVStream* stream = nullptr;
  int rotation_cw_deg = 0;        // clockwise rotation that shows the frame upright
  int64_t first_pts = AV_NOPTS_VALUE;
  bool draining = false;          // end of input reached, the decoder was sent the flush packet
  bool pending = false;           // `frame` holds a frame the next Grab() delivers (after Seek)
  // What `sws` was made for: a new context (same parameters or not, possibly at the old one's
  // address) needs its colour matrix and range set again.
  std::array<int, 8> sws_key{};

  // Opens (or opens again, at the start) the file and its decoder. Throws InputError.
  void Open();
  static int InterruptTrampoline(void* opaque) {
    const Impl* self = static_cast<const Impl*>(opaque);
    return self->interrupt && self->interrupt() ? 1 : 0;
  }
  // Decodes the next frame into `frame`; false at the end of the stream.
  bool DecodeFrame();
  int64_t FrameTimestamp() const;
  // Index of the frame at presentation time `pts` (rounded), counted from the first frame.
  int64_t IndexOfPts(int64_t pts, double fps) const;
  bool SeekToTimestamp(int64_t pts);
  cv::Size DisplaySize() const;
};

bool VideoDecoder::Impl::DecodeFrame() {
  for (;;) {
    const int received = avcodec_receive_frame(codec.get(), frame.get());
    if (received == 0) return true;
    if (received == AVERROR_EOF) return false;
    if (received != AVERROR(EAGAIN)) {
      GLAM_LOG_DEBUG("'{}': decoder error {}", name, AvErrorText(received));
    }
    if (draining) return false;  // nothing more to give it
    // The decoder wants input: the next packet of our stream, skipping those it rejects
    // (a corrupt packet costs its frame, not the rest of the video).
    for (;;) {
      const int read = av_read_frame(format.get(), packet.get());
      if (read < 0) {
        if (read != AVERROR_EOF) {
          GLAM_LOG_DEBUG("'{}': read stopped: {}", name, AvErrorText(read));
        }
        avcodec_send_packet(codec.get(), nullptr);  // flush the frames still inside
        draining = true;
        break;
      }
      if (packet->stream_index != stream->index) {
        av_packet_unref(packet.get());
        continue;
      }
      const int sent = avcodec_send_packet(codec.get(), packet.get());
      av_packet_unref(packet.get());
      if (sent < 0) {
        GLAM_LOG_DEBUG("'{}': packet skipped: {}", name, AvErrorText(sent));
        continue;
      }
      break;
    }
  }
}

int64_t VideoDecoder::Impl::FrameTimestamp() const {
  return frame->best_effort_timestamp != AV_NOPTS_VALUE ? frame->best_effort_timestamp
                                                        : frame->pts;
}

int64_t VideoDecoder::Impl::IndexOfPts(int64_t pts, double fps) const {
  const double seconds = static_cast<double>(pts - first_pts) * av_q2d(stream->time_base);
  return static_cast<int64_t>(std::llround(seconds * fps));
}

bool VideoDecoder::Impl::SeekToTimestamp(int64_t pts) {
  if (av_seek_frame(format.get(), stream->index, pts, AVSEEK_FLAG_BACKWARD) < 0) return false;
  avcodec_flush_buffers(codec.get());
  draining = false;
  pending = false;
  return true;
}

cv::Size VideoDecoder::Impl::DisplaySize() const {
  if (frame->width <= 0) return {};
  const bool sideways = rotation_cw_deg == 90 || rotation_cw_deg == 270;
  return sideways ? cv::Size(frame->height, frame->width) : cv::Size(frame->width, frame->height);
}

void VideoDecoder::Impl::Open() {
  codec.reset();
  format.reset();
  sws.reset();
  sws_key = {};
  draining = false;
  pending = false;

  AVFormatContext* raw_format = avformat_alloc_context();
  if (raw_format == nullptr) throw EnvironmentError("out of memory allocating a video demuxer");
  if (interrupt) {
    raw_format->interrupt_callback.callback = &InterruptTrampoline;
    raw_format->interrupt_callback.opaque = this;
  }
  AVDictionary* dictionary = nullptr;
  for (const auto& [key, value] : format_options) av_dict_set(&dictionary, key.c_str(), value.c_str(), 0);
  // On failure avformat_open_input frees the context.
  const int opened = avformat_open_input(&raw_format, path.c_str(), nullptr, &dictionary);
  // What is left in the dictionary was not consumed, but only an open that got through tells:
  // a failed one (a stream that never came) leaves every option there.
  const AVDictionaryEntry* unused = nullptr;
  while (opened >= 0 && (unused = av_dict_get(dictionary, "", unused, AV_DICT_IGNORE_SUFFIX)) != nullptr) {
    GLAM_LOG_WARN("'{}': FFmpeg option {}={} not recognised; ignored", name, unused->key,
                  unused->value);
  }
  av_dict_free(&dictionary);
  if (opened < 0) {
    throw InputError(fmt::format("cannot open '{}' as a video ({}): not a video file, or a "
                                 "container FFmpeg cannot read",
                                 name, AvErrorText(opened)));
  }
  format.reset(raw_format);
  if (avformat_find_stream_info(format.get(), nullptr) < 0) {
    throw InputError(fmt::format("cannot read the streams of '{}': not a video file",
                                 name));
  }
  const AVCodec* decoder = nullptr;
  const int stream_index =
      av_find_best_stream(format.get(), AVMEDIA_TYPE_VIDEO, -1, -1, &decoder, 0);
  if (stream_index == AVERROR_DECODER_NOT_FOUND) {
    throw InputError(fmt::format("'{}' has a video stream in a codec FFmpeg cannot decode here",
                                 name));
  }
  if (stream_index < 0 || decoder == nullptr) {
    throw InputError(fmt::format("'{}' has no video stream", name));
  }
  stream = format->streams[stream_index];
  // Only our stream's packets are demuxed in full; the others (audio, telemetry) are dropped.
  for (unsigned i = 0; i < format->nb_streams; ++i) {
    if (static_cast<int>(i) != stream_index) format->streams[i]->discard = AVDISCARD_ALL;
  }

  codec.reset(avcodec_alloc_context3(decoder));
  if (!codec) throw EnvironmentError("out of memory allocating a video decoder");
  if (avcodec_parameters_to_context(codec.get(), stream->codecpar) < 0) {
    throw InputError(fmt::format("'{}': unusable video stream parameters", name));
  }
  codec->thread_count = threads;
  const int codec_opened = avcodec_open2(codec.get(), decoder, nullptr);
  if (codec_opened < 0) {
    throw InputError(fmt::format("cannot start the {} decoder for '{}': {}", decoder->name,
                                 name, AvErrorText(codec_opened)));
  }

  // The display matrix holds the counter-clockwise rotation of the stored picture.
  rotation_cw_deg = 0;
  const uint8_t* matrix = av_stream_get_side_data(stream, AV_PKT_DATA_DISPLAYMATRIX, nullptr);
  if (matrix != nullptr) {
    const double ccw = av_display_rotation_get(reinterpret_cast<const int32_t*>(matrix));
    if (std::isfinite(ccw)) {
      const int quarter = static_cast<int>(std::lround(-ccw / 90.0));
      rotation_cw_deg = ((quarter % 4 + 4) % 4) * 90;
    }
  }
}

VideoDecoder::VideoDecoder(const std::filesystem::path& path, const VideoDecoderOptions& options)
    : impl_(std::make_unique<Impl>()) {
  options.Check();
  InstallLibavLogCallback();
  Impl& d = *impl_;
  d.path = path;
  d.name = options.display_name.empty() ? path.string() : options.display_name;
  d.threads = options.threads;
  d.format_options = options.format_options;
  d.interrupt = options.interrupt;
  if (!d.frame || !d.packet) throw EnvironmentError("out of memory allocating a video frame");
  d.Open();
}

VideoDecoder::~VideoDecoder() = default;

double VideoDecoder::fps() const {
  const AVStream* stream = impl_->stream;
  double rate = av_q2d(stream->avg_frame_rate);
  if (!(rate > 0.0) || !std::isfinite(rate)) rate = av_q2d(stream->r_frame_rate);
  return rate > 0.0 && std::isfinite(rate) ? rate : 0.0;
}

int64_t VideoDecoder::announced_frame_count() const {
  const AVStream* stream = impl_->stream;
  if (stream->nb_frames > 0) return stream->nb_frames;
  double seconds = impl_->format->duration > 0
                       ? static_cast<double>(impl_->format->duration) / AV_TIME_BASE
                       : 0.0;
  if (!(seconds > 0.0) && stream->duration > 0) {
    seconds = static_cast<double>(stream->duration) * av_q2d(stream->time_base);
  }
  const double count = std::floor(seconds * fps() + 0.5);
  return count >= 1.0 && std::isfinite(count) ? static_cast<int64_t>(count) : -1;
}

bool VideoDecoder::Grab() {
  Impl& d = *impl_;
  if (d.pending) {
    d.pending = false;
    ++index_;
    return true;
  }
  if (!d.DecodeFrame()) return false;
  if (index_ < 0) d.first_pts = d.FrameTimestamp();
  ++index_;
  return true;
}

cv::Size VideoDecoder::display_size() const { return impl_->DisplaySize(); }

std::optional<double> VideoDecoder::seconds_since_first() const {
  const Impl& d = *impl_;
  if (index_ < 0 || d.first_pts == AV_NOPTS_VALUE) return std::nullopt;
  const int64_t pts = d.FrameTimestamp();
  if (pts == AV_NOPTS_VALUE) return std::nullopt;
  return static_cast<double>(pts - d.first_pts) * av_q2d(d.stream->time_base);
}

void VideoDecoder::Retrieve(cv::Size size, cv::Mat* bgr) {
  Impl& d = *impl_;
  GLAM_CHECK(index_ >= 0 && d.frame->width > 0, "Retrieve() before a successful Grab()");
  GLAM_CHECK(size.width > 0 && size.height > 0, "bad output size {}x{}", size.width, size.height);
  const bool sideways = d.rotation_cw_deg == 90 || d.rotation_cw_deg == 270;
  const cv::Size scaled = sideways ? cv::Size(size.height, size.width) : size;

  bool full_range = d.frame->color_range == AVCOL_RANGE_JPEG;
  const AVPixelFormat source_format =
      WithoutJpegRange(static_cast<AVPixelFormat>(d.frame->format), &full_range);
  const bool downscale = scaled.width < d.frame->width || scaled.height < d.frame->height;
  const int flags = downscale ? SWS_AREA : SWS_BICUBIC;
  const int colourspace = SwsColorspace(d.frame->colorspace);
  const std::array<int, 8> key = {d.frame->width, d.frame->height, source_format, scaled.width,
                                   scaled.height,  flags,           colourspace,   full_range};
  if (key != d.sws_key || !d.sws) {
    d.sws.reset(sws_getContext(d.frame->width, d.frame->height, source_format, scaled.width,
                               scaled.height, AV_PIX_FMT_BGR24, flags, nullptr, nullptr,
                               nullptr));
    d.sws_key = {};
    if (d.sws) {
      sws_setColorspaceDetails(d.sws.get(), sws_getCoefficients(colourspace), full_range ? 1 : 0,
                               sws_getCoefficients(SWS_CS_DEFAULT), 1, 0, 1 << 16, 1 << 16);
      d.sws_key = key;
    }
  }
  SwsContext* sws = d.sws.get();
  if (sws == nullptr) {
    throw InputError(fmt::format("'{}': cannot convert {} frames of {}x{} to BGR",
                                       d.name,
                                       av_get_pix_fmt_name(source_format) != nullptr
                                           ? av_get_pix_fmt_name(source_format)
                                           : "unknown",
                                       d.frame->width, d.frame->height));
  }

  // One spare row: some swscale output paths write a few bytes past the last pixel.
  cv::Mat buffer(scaled.height + 1, scaled.width, CV_8UC3);
  cv::Mat out = buffer.rowRange(0, scaled.height);
  uint8_t* planes[4] = {out.data, nullptr, nullptr, nullptr};
  int strides[4] = {static_cast<int>(out.step[0]), 0, 0, 0};
  sws_scale(sws, d.frame->data, d.frame->linesize, 0, d.frame->height, planes, strides);

  switch (d.rotation_cw_deg) {
    case 90: cv::rotate(out, *bgr, cv::ROTATE_90_CLOCKWISE); break;
    case 180: cv::rotate(out, *bgr, cv::ROTATE_180); break;
    case 270: cv::rotate(out, *bgr, cv::ROTATE_90_COUNTERCLOCKWISE); break;
    default: *bgr = out;
  }
}

bool VideoDecoder::Seek(int64_t target) {
  Impl& d = *impl_;
  GLAM_CHECK(target >= 0, "seek to frame {}", target);
  const double rate = fps();
  // The first frame's time is the origin of the frame count.
  if (index_ < 0 && !Grab()) return false;
  const bool timed = d.first_pts != AV_NOPTS_VALUE && rate > 0.0;

  // Seek some frames before the target: the container maps a time to the key frame at or
  // before it where it has an index (MP4, MKV), but without one (MPEG-TS) the decoder may only
  // start at the next key frame after it, so go further back while it lands behind the target.
  for (int64_t back = 16; timed; back *= 2) {
    const int64_t start = std::max<int64_t>(0, target - back);
    const double start_s = static_cast<double>(start) / rate;
    const int64_t pts =
        d.first_pts + static_cast<int64_t>(std::llround(start_s / av_q2d(d.stream->time_base)));
    if (!d.SeekToTimestamp(pts)) break;  // the container cannot seek
    const bool decoded = d.DecodeFrame();
    const int64_t landed = decoded ? d.FrameTimestamp() : AV_NOPTS_VALUE;
    if (decoded && landed == AV_NOPTS_VALUE) break;  // no timestamps to count by
    int64_t at = decoded ? d.IndexOfPts(landed, rate) : target + 1;
    if (at > target) {  // behind the target, or past the end
      if (start == 0) break;
      continue;
    }
    return DecodeForwardTo(at, target);
  }

  // No usable timestamps, or no seek lands at or before the target: open the file again and
  // count frames from the start (slow for a far target, but exact).
  GLAM_LOG_DEBUG("'{}': seeking to frame {} by decoding from the start", d.name, target);
  d.Open();
  if (!d.DecodeFrame()) {
    index_ = -1;
    return false;
  }
  return DecodeForwardTo(0, target);
}

bool VideoDecoder::DecodeForwardTo(int64_t at, int64_t target) {
  Impl& d = *impl_;
  for (; at < target; ++at) {
    if (!d.DecodeFrame()) {
      index_ = at;  // the last frame there is
      return false;
    }
  }
  d.pending = true;  // the next Grab() delivers it
  index_ = target - 1;
  return true;
}

}  // namespace glam
