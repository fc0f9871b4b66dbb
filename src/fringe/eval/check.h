// The VDI/VDE 2634-2 acceptance test as one function (`fringe check`): a certified artefact
// (eval/artefact.h) measured in one or more positions of the working volume; per position the
// figures PF, PS (sphere), SD (ball bar) and F (plane) of vdi2634.h (the same functions
// `fringe evaluate` runs, so the figures are identical), each against its maximum permissible
// error, and a verdict.
//
// Verdict: a figure passes when PF <= MPE_PF, |PS| <= MPE_PS, |SD| <= MPE_SD, F <= MPE_F (the
// standard's acceptance test compares the measured error with the MPE; the certificate's
// uncertainties are reported beside it, not subtracted). The check passes when every figure of
// every artefact in the file was measured in at least one position and every measured figure
// passes; it fails when a measured figure exceeds its MPE; otherwise it is incomplete (an
// artefact found in no position, or a figure measured without an MPE in the file).
//
// An artefact of the file that a position's cloud does not show (not found) is reported for
// that position and does not count against it: positions are usually chosen so that each shows
// only some of the artefacts.
//
// Units: millimetres. Thread safety: pure functions.
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "fringe/eval/artefact.h"
#include "fringe/eval/vdi2634.h"
#include "fringe/geometry/point_cloud.h"
#include "fringe/io/report.h"

namespace fringe::eval {

struct CheckOptions {
  VdiOptions vdi;  // the artefact search and the 0.3 % allowance, as `fringe evaluate`
  void Check() const;
};

// One measured figure against its MPE.
struct CheckFigure {
  std::string name;  // "PF", "PS", "SD", "F"
  bool measured = false;
  double value_mm = 0;  // signed for PS and SD
  double mpe_mm = 0;    // 0: no MPE in the file (no verdict)
  bool pass = false;    // measured, with an MPE, and within it
  bool has_verdict() const { return measured && mpe_mm > 0; }
};

struct CheckPosition {
  std::string name;  // the cloud's file or view name
  size_t points = 0;
  std::optional<SphereResult> sphere;    // when the file has a sphere
  std::optional<BallBarResult> ballbar;  // when the file has a ball bar
  std::optional<PlaneResult> plane;      // when the file has a plane
  std::vector<CheckFigure> figures;      // in the order PF, PS, SD, F, those the file asks for
};

enum class CheckStatus { kPass = 0, kFail, kIncomplete };
const char* ToString(CheckStatus s);

struct CheckSummary {
  CheckStatus status = CheckStatus::kIncomplete;
  std::string message;  // why it failed or is incomplete (names the position and figure)
  std::vector<CheckPosition> positions;
  // Per figure the largest |value| over the positions where it was measured; measured = false
  // when no position measured it.
  std::vector<CheckFigure> worst;
  bool passed() const { return status == CheckStatus::kPass; }
  std::string BriefReport() const;
  // The table of figures per position against the MPE, as plain text.
  std::string Table() const;
};

struct CheckInput {
  std::string name;
  PointCloud cloud;
};

// Throws fringe::Error when `inputs` is empty or the options are bad.
CheckSummary CheckArtefact(const std::vector<CheckInput>& inputs, const Artefact& artefact,
                           const CheckOptions& options = {});

// check.json: the artefact, the options, per position the figures and the vdi2634 results, the
// worst figures and the verdict.
nlohmann::json ToJson(const CheckSummary& s, const Artefact& artefact, const CheckOptions& options);
// The HTML page: the verdict, the table of figures per position against the MPE, the
// certificate, and a bar chart of each figure's ratio to its MPE per position.
io::Report CheckReport(const CheckSummary& s, const Artefact& artefact);

}  // namespace fringe::eval
