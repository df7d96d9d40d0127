#include "api/job_json.h"
#include "api/stream_url.h"
#include "engine/video/stream_source.h"
#include "api/api_error.h"

#include <gtest/gtest.h>

#include "engine/core/error.h"

namespace glam::api {
namespace {

using nlohmann::json;

TEST(JobJson, ParsesOptionsAndMapsThemToEngineOptions) {
  const JobOptions o = ParseJobOptionsText(R"({"name": "flight 1", "stride": 2, "focal": 900.5,
      "keyframes_per_submap": 8, "detect_every": 1, "detect_max_seconds": 0.5,
      "intrinsics": {"model": "pinhole", "width": 640, "height": 360, "fx": 500, "fy": 501,
                     "cx": 319.5, "cy": 179.5}})");
  EXPECT_EQ(o.name, "flight 1");
  ASSERT_TRUE(o.stride && o.focal && o.intrinsics && o.keyframes_per_submap);
  EXPECT_EQ(*o.stride, 2);
  EXPECT_DOUBLE_EQ(*o.focal, 900.5);
  EXPECT_DOUBLE_EQ(o.intrinsics->fy, 501);
  const MappingOptions m = ToMappingOptions(o);
  EXPECT_EQ(m.source.stride, 2);
  EXPECT_EQ(m.submap.keyframes_per_submap, 8);
  EXPECT_EQ(m.detection_interval, 1);
  EXPECT_DOUBLE_EQ(m.max_detection_seconds, 0.5);
  EXPECT_EQ(ToMappingOptions(JobOptions{}).max_detection_seconds, 0.0);  // fixed schedule by default
  EXPECT_EQ(ToMappingOptions(JobOptions{}).detection_interval, 0);  // automatic by default
  ASSERT_TRUE(m.intrinsics.has_value());
  EXPECT_DOUBLE_EQ(m.intrinsics->cx, 319.5);
  // A given calibration is trusted (as `glam map --intrinsics`): neither focal nor k1 refined;
  // without one both are estimated.
  EXPECT_FALSE(m.submap.bundle_adjustment.refine_focal);
  EXPECT_FALSE(m.submap.bundle_adjustment.refine_k1);
  EXPECT_TRUE(ToMappingOptions(JobOptions{}).submap.bundle_adjustment.refine_focal);
  EXPECT_TRUE(ToMappingOptions(JobOptions{}).submap.bundle_adjustment.refine_k1);
  // fixed_k1 keeps k1 (as `glam map --fixed-k1`) and leaves the focal estimated.
  const JobOptions fixed = ParseJobOptionsText(R"({"fixed_k1": true})");
  ASSERT_TRUE(fixed.fixed_k1.has_value());
  EXPECT_FALSE(ToMappingOptions(fixed).submap.bundle_adjustment.refine_k1);
  EXPECT_TRUE(ToMappingOptions(fixed).submap.bundle_adjustment.refine_focal);
  EXPECT_TRUE(ToMappingOptions(ParseJobOptionsText(R"({"fixed_k1": false})")).submap.bundle_adjustment.refine_k1);
  EXPECT_EQ(ToJson(fixed), json::parse(R"({"fixed_k1": true})"));
  // smooth_window_s sets the centre smoothing's half width (as `glam map --smooth-window`).
  const JobOptions smooth = ParseJobOptionsText(R"({"smooth_window_s": 0})");
  EXPECT_EQ(ToMappingOptions(smooth).submap.centre_smoothing.half_window_s, 0.0);
  EXPECT_EQ(ToMappingOptions(JobOptions{}).submap.centre_smoothing.half_window_s,
            CentreSmoothingOptions{}.half_window_s);
  EXPECT_EQ(ToJson(smooth), json::parse(R"({"smooth_window_s": 0.0})"));
  // preview_interval_s paces the open submap's provisional tiles (as `glam map --preview-interval`).
  const JobOptions no_preview = ParseJobOptionsText(R"({"preview_interval_s": 0})");
  EXPECT_EQ(ToMappingOptions(no_preview).preview.interval_s, 0.0);
  EXPECT_EQ(ToMappingOptions(JobOptions{}).preview.interval_s, OpenSubmapPreviewOptions{}.interval_s);
  EXPECT_EQ(ToJson(no_preview), json::parse(R"({"preview_interval_s": 0.0})"));
  // name_order maps a photo job's photos in name order (as `glam map --name-order`).
  const JobOptions named = ParseJobOptionsText(R"({"name_order": true})");
  EXPECT_FALSE(ToMappingOptions(named).source.photos_by_capture_time);
  EXPECT_TRUE(ToMappingOptions(ParseJobOptionsText(R"({"name_order": false})")).source.photos_by_capture_time);
  EXPECT_TRUE(ToMappingOptions(JobOptions{}).source.photos_by_capture_time);
  EXPECT_EQ(ToJson(named), json::parse(R"({"name_order": true})"));
  // refine_focal refines the focal of given intrinsics (as `glam map --intrinsics F
  // --refine-focal`); k1 stays fixed. Without intrinsics the focal is refined anyway.
  const JobOptions refined = ParseJobOptionsText(R"({"refine_focal": true,
      "intrinsics": {"model": "pinhole", "width": 640, "height": 360, "fx": 500, "fy": 500,
                     "cx": 319.5, "cy": 179.5}})");
  EXPECT_TRUE(ToMappingOptions(refined).submap.bundle_adjustment.refine_focal);
  EXPECT_FALSE(ToMappingOptions(refined).submap.bundle_adjustment.refine_k1);
  const JobOptions not_refined = ParseJobOptionsText(R"({"refine_focal": false})");
  EXPECT_TRUE(ToMappingOptions(not_refined).submap.bundle_adjustment.refine_focal);  // estimated anyway
  EXPECT_EQ(ToJson(refined)["refine_focal"], true);
  // max_features sets the SIFT budget per frame (as `glam map --max-features`).
  const JobOptions features = ParseJobOptionsText(R"({"max_features": 4000})");
  EXPECT_EQ(ToMappingOptions(features).sift.max_features, 4000);
  EXPECT_EQ(ToMappingOptions(JobOptions{}).sift.max_features, SiftOptions{}.max_features);
  EXPECT_EQ(ToJson(features), json::parse(R"({"max_features": 4000})"));
  // global_refinement_keyframes bounds the end-of-run refinement (0 = rigid submaps).
  const JobOptions rigid = ParseJobOptionsText(R"({"global_refinement_keyframes": 0})");
  EXPECT_EQ(ToMappingOptions(rigid).global_refinement.max_keyframes, 0);
  EXPECT_EQ(ToMappingOptions(JobOptions{}).global_refinement.max_keyframes,
            GlobalRefinementOptions{}.max_keyframes);
  EXPECT_EQ(ToJson(rigid), json::parse(R"({"global_refinement_keyframes": 0})"));
  // rolling_shutter_ms is the camera's readout time (0 = global shutter, the default).
  const JobOptions rolling = ParseJobOptionsText(R"({"rolling_shutter_ms": 28.5})");
  EXPECT_EQ(ToMappingOptions(rolling).rolling_shutter.readout_ms, 28.5);
  EXPECT_FALSE(ToMappingOptions(rolling).rolling_shutter.estimate);
  EXPECT_TRUE(ToMappingOptions(JobOptions{}).rolling_shutter.estimate);  // the default: estimated
  const JobOptions global = ParseJobOptionsText(R"({"rolling_shutter_ms": 0})");
  EXPECT_FALSE(ToMappingOptions(global).rolling_shutter.enabled());
  EXPECT_EQ(ToJson(rolling), json::parse(R"({"rolling_shutter_ms": 28.5})"));
  const JobOptions estimated = ParseJobOptionsText(R"({"rolling_shutter_ms": "auto"})");
  EXPECT_TRUE(ToMappingOptions(estimated).rolling_shutter.estimate);
  EXPECT_EQ(ToJson(estimated), json::parse(R"({"rolling_shutter_ms": "auto"})"));
  // Round trip through the stored JSON.
  const JobOptions back = ParseJobOptions(ToJson(o));
  EXPECT_EQ(ToJson(back), ToJson(o));
}

TEST(JobJson, RejectsBadOptionsWithTheKeyInTheMessage) {
  auto message = [](const std::string& text) {
    try {
      ParseJobOptionsText(text);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_NE(message("{not json").find("malformed JSON"), std::string::npos);
  EXPECT_NE(message("[1,2]").find("object"), std::string::npos);
  EXPECT_NE(message(R"({"strid": 2})").find("strid"), std::string::npos);
  EXPECT_NE(message(R"({"stride": "2"})").find("stride"), std::string::npos);
  EXPECT_NE(message(R"({"stride": 0})").find("stride"), std::string::npos);
  EXPECT_NE(message(R"({"focal": -5})").find("focal"), std::string::npos);
  EXPECT_NE(message(R"({"detect_every": -1})").find("detect_every"), std::string::npos);
  EXPECT_NE(message(R"({"detect_max_seconds": 11})").find("detect_max_seconds"), std::string::npos);
  EXPECT_NE(message(R"({"detect_max_seconds": "1"})").find("detect_max_seconds"), std::string::npos);
  EXPECT_NE(message(R"({"fixed_k1": "yes"})").find("fixed_k1"), std::string::npos);
  EXPECT_NE(message(R"({"fixed_k1": 1})").find("fixed_k1"), std::string::npos);
  EXPECT_NE(message(R"({"name_order": "yes"})").find("name_order"), std::string::npos);
  EXPECT_NE(message(R"({"refine_focal": "yes"})").find("refine_focal"), std::string::npos);
  EXPECT_NE(message(R"({"max_features": 99})").find("max_features"), std::string::npos);
  EXPECT_NE(message(R"({"max_features": 50001})").find("max_features"), std::string::npos);
  EXPECT_NE(message(R"({"max_features": 2000.5})").find("max_features"), std::string::npos);
  EXPECT_NE(message(R"({"global_refinement_keyframes": -1})").find("global_refinement_keyframes"),
            std::string::npos);
  EXPECT_NE(message(R"({"global_refinement_keyframes": 1001})").find("global_refinement_keyframes"),
            std::string::npos);
  EXPECT_NE(message(R"({"rolling_shutter_ms": -1})").find("rolling_shutter_ms"), std::string::npos);
  EXPECT_NE(message(R"({"rolling_shutter_ms": 101})").find("rolling_shutter_ms"), std::string::npos);
  EXPECT_NE(message(R"({"rolling_shutter_ms": "30"})").find("rolling_shutter_ms"), std::string::npos);
  EXPECT_NE(message(R"({"rolling_shutter_ms": "automatic"})").find("rolling_shutter_ms"), std::string::npos);
  EXPECT_NE(message(R"({"smooth_window_s": -0.1})").find("smooth_window_s"), std::string::npos);
  EXPECT_NE(message(R"({"preview_interval_s": 61})").find("preview_interval_s"), std::string::npos);
  EXPECT_NE(message(R"({"preview_interval_s": "often"})").find("preview_interval_s"), std::string::npos);
  EXPECT_NE(message(R"({"smooth_window_s": 6})").find("smooth_window_s"), std::string::npos);
  EXPECT_NE(message(R"({"smooth_window_s": "0.5"})").find("smooth_window_s"), std::string::npos);
  EXPECT_NE(message(R"({"intrinsics": {"model": "pinhole"}})").find("width"), std::string::npos);
  EXPECT_EQ(message("{}"), "accepted");
}

TEST(JobJson, JobJsonHasTheContractFields) {
  Job job;
  job.id = "0123456789abcdef";
  job.name = "clip.mp4";
  job.state = JobState::kRunning;
  job.created_ms = 1700000000123;
  job.updated_ms = 1700000001000;
  job.progress.frames_done = 12;
  job.progress.revision = 3;
  const json j = JobToJson(job);
  for (const char* key : {"id", "name", "state", "error", "created_at", "updated_at", "urls", "progress"}) {
    EXPECT_TRUE(j.contains(key)) << key;
  }
  EXPECT_EQ(j["state"], "running");
  EXPECT_TRUE(j["error"].is_null());
  EXPECT_EQ(j["created_at"], "2023-11-14T22:13:20.123Z");
  EXPECT_EQ(j["urls"]["trajectory"], "/api/v1/jobs/0123456789abcdef/trajectory.tum");
  for (const char* key : {"stage", "frames_done", "frames_total", "fps", "eta_s", "submaps_completed",
                          "submaps_aligned", "keyframes", "points", "revision"}) {
    EXPECT_TRUE(j["progress"].contains(key)) << key;
  }
  EXPECT_EQ(ProgressFromJson(j["progress"]).revision, 3);
  EXPECT_EQ(ErrorJson("not_found", "x")["error"]["code"], "not_found");
}

TEST(StreamUrl, CredentialsAreRedactedAndOnlyNetworkStreamsPass) {
  EXPECT_EQ(RedactStreamUrl("rtsp://cam:554/live"), "rtsp://cam:554/live");
  EXPECT_EQ(RedactStreamUrl("rtsp://admin:secret@10.0.0.2:554/live?x=a@b"), "rtsp://***@10.0.0.2:554/live?x=a@b");
  EXPECT_EQ(RedactStreamUrl("rtmp://user@host/app"), "rtmp://***@host/app");
  EXPECT_EQ(RedactStreamUrl("srt://host:9000?passphrase=topsecret&latency=200"),
            "srt://host:9000?passphrase=***&latency=200");
  EXPECT_EQ(RedactStreamUrl("http://host/feed.ts?token=abc"), "http://host/feed.ts?token=***");
  EXPECT_EQ(RedactStreamUrl("udp://@:5004"), "udp://@:5004");  // FFmpeg's "any address"
  EXPECT_EQ(RedactStreamUrl("rtmp://host/app?Key=k1&x=1#frag"), "rtmp://host/app?Key=***&x=1#frag");
  EXPECT_NO_THROW(CheckStreamUrl("srt://0.0.0.0:9000?mode=listener"));
  EXPECT_NO_THROW(CheckStreamUrl("HTTPS://host/live.m3u8"));
  EXPECT_THROW(CheckStreamUrl("tls://host:443"), ApiError);
}

}  // namespace
}  // namespace glam::api
