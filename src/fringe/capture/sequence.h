// The capture sequence: show pattern k on the projector, wait until it is presented plus the
// settle time (the measured latency between "presented" and "the cameras see it"), trigger
// every camera at once, grab one frame from each, next pattern. A frame that is incomplete
// (lost packets the stream could not recover), never comes (timeout) or repeats the previous
// frame id is not used: the pattern is shown again and every camera re-grabbed, at most
// SequenceOptions::max_retries times; a camera that is gone (control connection lost) ends the
// sequence at once. Either every camera has exactly one good frame per pattern, or the call
// throws fringe::Error naming the camera, the pattern and why — never a missing or duplicated
// image.
//
// Latency: MeasureLatency flips the projector between black and white and finds, by bisection
// on the delay between "presented" and the trigger, the smallest delay after which every
// camera sees the new level (LatencyOptions::seen_fraction of the black-to-white step).
#pragma once

#include <chrono>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "fringe/capture/camera.h"
#include "fringe/capture/projector.h"

namespace fringe::capture {

struct SequenceOptions {
  // Wait after a pattern was presented before the cameras are triggered, ms, in [0, 10000]
  // (the measured latency; `fringe capture` uses the project's measured one when it has one).
  double settle_ms = 100;
  // Longest wait for one camera's frame after the trigger, ms, in [1, 600000]. Add the
  // exposure: the sequencer waits grab_timeout_ms + exposure.
  int grab_timeout_ms = 2000;
  // Re-shows and re-grabs of one pattern after an incomplete, missing or repeated frame, in
  // [0, 100].
  int max_retries = 3;
  void Check() const;
};
nlohmann::json ToJson(const SequenceOptions& options);

// What happened to one accepted frame.
struct FrameRecord {
  int pattern = 0;                   // index in the scheme's image order
  int attempts = 1;                  // 1 + retries of this pattern
  uint64_t frame_id = 0;             // the device's frame counter
  uint64_t timestamp_ns = 0;         // device timestamp
  uint64_t system_timestamp_ns = 0;  // host time of arrival (ns since the epoch)
  double shown_s = 0;      // presentation time of the pattern, s after the sequence started
  double triggered_s = 0;  // trigger time, s after the sequence started
};

struct StackCapture {
  std::vector<std::vector<Frame>> frames;         // [camera][pattern]
  std::vector<std::vector<FrameRecord>> records;  // [camera][pattern]
  int retries = 0;                                // patterns shown again
  std::vector<std::string> retry_reasons;         // one per retry
  uint64_t frames_failed = 0;  // incomplete frames and timeouts seen (all cameras)
  double seconds = 0;          // wall time of the sequence
};

// Captures one image per pattern from every camera (Configure()d and Start()ed).
StackCapture CaptureStack(const std::vector<Camera*>& cameras, Projector& projector,
                          const std::vector<cv::Mat>& patterns, const SequenceOptions& options);

// One frame of every camera of a uniform projector level (0..255) held for settle_ms: white
// for board images, black/white references.
std::vector<Frame> CaptureLevel(const std::vector<Camera*>& cameras, Projector& projector,
                                int level, const SequenceOptions& options);

struct LatencyOptions {
  double max_latency_ms = 300;  // upper end of the bisection, ms, in (0, 10000]
  double resolution_ms = 1;     // bisection stops at this width, ms, in (0, max_latency_ms]
  // The camera sees the new frame when its mean level has covered this fraction of the
  // black-to-white step, in (0.5, 1).
  double seen_fraction = 0.9;
  // Smallest black-to-white step, as a fraction of full scale: less means the cameras do not
  // see the projector (wrong exposure, covered lens), in (0, 1).
  double min_contrast = 0.05;
  void Check() const;
};

struct LatencyResult {
  double latency_ms = 0;  // the settle time to use: every camera saw the new frame after it
  std::vector<double> black_dn, white_dn;  // per camera mean levels
  int probes = 0;                          // flips used
  double seconds = 0;
};
nlohmann::json ToJson(const LatencyResult& result);

// Throws fringe::Error naming the camera when it cannot tell black from white.
LatencyResult MeasureLatency(const std::vector<Camera*>& cameras, Projector& projector,
                             const LatencyOptions& options, const SequenceOptions& sequence);

// --auto-exposure: the longest exposure at which at most max_saturated_fraction of the lit
// pixels saturate under a white frame. A pixel is lit when the white frame raises it by at least
// min_lit_contrast of full scale over the black frame at the same exposure (the background and
// the pixels that do not see the projector do not count); it saturates at full scale
// (2^bit_depth - 1) under white. The saturated fraction grows with the exposure, so the search
// is a bisection on log(exposure) between the cameras' common range (capped at
// max_exposure_us), down to a bracket of relative width `resolution`. One exposure for all
// cameras: the longest at which every one of them is within the limit.
struct AutoExposureOptions {
  double max_saturated_fraction = 0.001;  // of the lit pixels, [0, 1)
  double min_lit_contrast = 0.02;         // of full scale, (0, 1)
  double max_exposure_us = 200000;        // upper end of the search (and the camera's maximum), > 0
  double resolution = 0.02;               // relative width of the final bracket, (0, 1)
  void Check() const;
};

// Which pixels of a camera the projector lights, from one frame under a black and one under a
// white projector frame (same exposure): lit where white - black >= min_lit_contrast of full
// scale, saturated where lit and white is at full scale (2^bit_depth - 1). The one
// classification of --auto-exposure (FindExposure) and --preview (preview.h).
struct LitPixels {
  cv::Mat lit;                    // CV_8UC1, 255 where lit
  cv::Mat saturated;              // CV_8UC1, 255 where lit and saturated under white
  double lit_fraction = 0;        // of the image
  double saturated_fraction = 0;  // of the lit pixels (0 when none is lit)
};
LitPixels ClassifyLit(const Frame& black, const Frame& white, double min_lit_contrast);

struct AutoExposureProbe {
  double exposure_us = 0;
  std::vector<double> saturated_fraction;  // per camera, of its lit pixels
  std::vector<double> lit_fraction;        // per camera, of the image
};

struct AutoExposureResult {
  double exposure_us = 0;         // chosen
  double min_us = 0, max_us = 0;  // the range searched
  std::vector<AutoExposureProbe> probes;
  AutoExposureProbe chosen;  // the figures at the chosen exposure
  double seconds = 0;
};
nlohmann::json ToJson(const AutoExposureResult& result);

// Searches the exposure on Configure()d, Start()ed cameras (reconfigured with `settings` at each
// probed exposure, and left configured and started at the chosen one). Throws fringe::Error
// naming the camera when it does not report an exposure range, and when even the shortest
// exposure saturates too many lit pixels (lower the gain or close the aperture).
AutoExposureResult FindExposure(const std::vector<Camera*>& cameras, Projector& projector,
                                const CameraSettings& settings, const AutoExposureOptions& options,
                                const SequenceOptions& sequence);

}  // namespace fringe::capture
