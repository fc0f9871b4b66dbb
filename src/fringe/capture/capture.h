// `fringe capture`: one view (or one calibration board pose) captured into a scan folder
// (docs/scan-folder.md, "Captured scan folders"). The project folder is created the first time
// (scan.json, scheme.json); every capture appends the next view views/NNN/{left,right}/
// atomically — the images and views/NNN/capture.json (settings, frame ids, timestamps) are
// written into a hidden temporary folder that is renamed into views/ when complete, then
// scan.json is rewritten (temporary + rename) with the new count. A failed capture leaves no
// view behind and the views already captured untouched; the next capture continues the
// numbering. The project's measured latency lives in PROJECT/capture.json.
//
// Thread safety: one capture per project at a time (the numbering is read from scan.json).
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "fringe/capture/camera.h"
#include "fringe/capture/feedback.h"
#include "fringe/capture/sequence.h"
#include "fringe/phase/decode.h"
#include "fringe/phase/pattern_scheme.h"

namespace fringe::capture {

struct CaptureOptions {
  // Camera specs (OpenCamera): the left camera, and the right one (empty: one camera, a
  // camera + projector scan folder).
  std::string left;
  std::string right;
  std::string projector;  // projector screen (Projector::Open)
  CameraSettings camera;  // exposure, gain, pixel format, ROI, trigger of both cameras
  // Exposures of an HDR stack, us: empty or one value captures one stack at
  // camera.exposure_us (or that value); several capture the stack at each into e0/, e1/, ...
  std::vector<double> exposures_us;
  SequenceOptions sequence;
  // Settle time: < 0 uses the project's measured latency (PROJECT/capture.json), or
  // sequence.settle_ms when it was never measured; >= 0 overrides both, ms.
  double settle_ms = -1;
  // --auto-exposure: before capturing, the longest exposure at which at most 0.1 % of the lit
  // pixels saturate under a white frame (FindExposure) replaces camera.exposure_us. Not with
  // several exposures_us.
  bool auto_exposure = false;
  AutoExposureOptions auto_exposure_options;
  // Measure the latency first (MeasureLatency) and store it in PROJECT/capture.json.
  bool measure_latency = false;
  LatencyOptions latency;
  // Capture a calibration board pose instead of a view: two cameras, a plain image of each
  // under a white frame into calibration/{left,right}/KKK.png; one camera (camera + projector
  // calibration), the pose folder calibration/KKK/ with board.png (white frame) and the camera's
  // fringe stacks of both directions in vertical/ and horizontal/ with their manifest.json
  // (calib/projector_folder.h), plus the pose's capture.json. `target_file` (a target
  // JSON, docs/formats.md) is copied to calibration/target.json the first time.
  bool board = false;
  std::filesystem::path target_file;
  // One-camera --board: the horizontal-fringe scheme (unset: the scheme with its direction turned
  // horizontal, same periods and steps, named "<name>-horizontal").
  std::optional<phase::PatternScheme> horizontal_scheme;
  // Decode the new view for the feedback (ViewFeedback); off: only the capture is reported.
  bool feedback = true;
  phase::DecodeOptions decode;  // for the feedback
  // The rig for the 3D feedback (reconstruction, markers, registration to the previous views,
  // feedback.h): this rig file, else PROJECT/rig.json when it exists; neither: the 3D feedback
  // is left out (CaptureSummary::view_message says so).
  std::filesystem::path rig_file;
  ViewFeedbackOptions view_feedback;  // its decode options are `decode`
  void Check() const;
};

// After each view: is it good? Figures of the left camera's stack (and the right one's).
struct CameraFeedback {
  std::string camera;         // "left" | "right"
  double saturated_pct = 0;   // pixels at full scale in any phase image, % of the image
  double modulated_pct = 0;   // pixels with enough fringe modulation, % of the image
  double decodable_pct = 0;   // pixels the decoder accepts, % of the image
  std::string decode_status;  // phase::DecodeStatus name
};

struct CaptureSummary {
  std::string kind;                                 // "view" | "board"
  std::string name;                                 // "003" (view) or "003" (board pose)
  std::filesystem::path path;                       // the new view folder or board image
  std::vector<CameraInfo> cameras;                  // left (, right)
  double latency_ms = -1;                           // measured now (-1: not measured)
  double exposure_us = 0;                           // the (first) exposure used
  std::optional<AutoExposureResult> auto_exposure;  // when --auto-exposure chose it
  double settle_ms = 0;                             // the settle time used
  int patterns = 0;                                 // images per camera and exposure
  int exposures = 1;
  int retries = 0;
  uint64_t frames_failed = 0;    // incomplete frames and timeouts (every camera)
  uint64_t resent_packets = 0;   // GigE Vision packets lost and resent (every camera)
  uint64_t missing_packets = 0;  // GigE Vision packets lost for good (their frames retried)
  double capture_s = 0;          // sequence time (all exposures)
  double total_s = 0;            // with opening the devices, writing and the feedback
  std::vector<CameraFeedback> feedback;
  // The 3D feedback of the new view (markers seen; once two views exist, whether it registers
  // to the previous ones and its overlap), when a rig was available.
  std::optional<ViewFeedback> view;
  std::string view_message;  // why there is no 3D feedback (no rig, the rig does not fit)
  std::string BriefReport() const;
};
nlohmann::json ToJson(const CaptureSummary& summary);

// Opens the cameras and the projector, captures and appends one view (or board pose) to
// `project` (created when it does not exist). The scheme must match an existing project's
// scheme.json, and the cameras its image size, bit depth and camera count. Throws
// fringe::Error naming the device and the step on any failure; nothing is then written.
CaptureSummary CaptureIntoProject(const std::filesystem::path& project,
                                  const phase::PatternScheme& scheme,
                                  const CaptureOptions& options);

// The measured latency stored in PROJECT/capture.json, if any.
std::optional<double> ReadProjectLatency(const std::filesystem::path& project);

// The figures of one camera's captured stack (CameraFeedback), from phase::Decode.
CameraFeedback AssessStack(const phase::PatternScheme& scheme, const std::vector<cv::Mat>& images,
                           int bit_depth, const phase::DecodeOptions& decode);

// `fringe devices`: cameras of every backend and the screens of an X11 display.
struct DeviceList {
  std::vector<CameraInfo> cameras;
  std::vector<ScreenInfo> screens;
  std::string screens_error;  // why no screen was listed (no display), else empty
};
DeviceList ListDevices(const std::string& display = "", bool probe_opencv = true);
nlohmann::json ToJson(const DeviceList& devices);

}  // namespace fringe::capture
