#include "fringe/eval/check.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "fringe/util/error.h"

namespace fringe::eval {
namespace {

using util::StrCat;

std::string Mm(double v, int digits = 4) {
  std::ostringstream os;
  os << std::fixed << std::setprecision(digits) << v;
  return os.str();
}

CheckFigure Figure(const char* name, bool measured, double value_mm, double mpe_mm) {
  CheckFigure f;
  f.name = name;
  f.measured = measured;
  f.value_mm = measured ? value_mm : 0;
  f.mpe_mm = mpe_mm;
  f.pass = f.has_verdict() && std::abs(f.value_mm) <= mpe_mm;
  return f;
}

std::string Verdict(const CheckFigure& f) {
  if (!f.measured) return "not measured";
  if (!(f.mpe_mm > 0)) return "no MPE";
  return f.pass ? "pass" : "FAIL";
}

std::string Cell(const CheckFigure& f) {
  return f.measured ? StrCat(Mm(f.value_mm), " (", Verdict(f), ")") : "-";
}

// The names of the figures the artefact file asks for, in the order PF, PS, SD, F.
std::vector<const char*> FigureNames(const Artefact& a) {
  std::vector<const char*> names;
  if (a.sphere) {
    names.push_back("PF");
    names.push_back("PS");
  }
  if (a.ballbar) names.push_back("SD");
  if (a.plane) names.push_back("F");
  return names;
}

double MpeOf(const Artefact& a, const std::string& name) {
  return name == "PF"   ? a.mpe.PF_mm
         : name == "PS" ? a.mpe.PS_mm
         : name == "SD" ? a.mpe.SD_mm
                        : a.mpe.F_mm;
}

nlohmann::json FigureJson(const CheckFigure& f) {
  nlohmann::json j = {{"measured", f.measured}, {"verdict", Verdict(f)}};
  if (f.measured) j["value_mm"] = f.value_mm;
  if (f.mpe_mm > 0) {
    j["mpe_mm"] = f.mpe_mm;
    if (f.measured) j["ratio_to_mpe"] = std::abs(f.value_mm) / f.mpe_mm;
  }
  return j;
}

}  // namespace

void CheckOptions::Check() const { vdi.Check(); }

const char* ToString(CheckStatus s) {
  switch (s) {
    case CheckStatus::kPass:
      return "pass";
    case CheckStatus::kFail:
      return "fail";
    case CheckStatus::kIncomplete:
      return "incomplete";
  }
  return "unknown";
}

CheckSummary CheckArtefact(const std::vector<CheckInput>& inputs, const Artefact& artefact,
                           const CheckOptions& options) {
  options.Check();
  if (inputs.empty()) throw Error("check: no measurement of the artefact given");
  if (!artefact.sphere && !artefact.ballbar && !artefact.plane) {
    throw Error("check: the artefact file describes no artefact");
  }
  CheckSummary s;
  for (const CheckInput& in : inputs) {
    CheckPosition p;
    p.name = in.name;
    p.points = in.cloud.size();
    if (artefact.sphere) {
      p.sphere = EvaluateSphere(in.cloud, artefact.sphere->diameter_mm, options.vdi);
      p.figures.push_back(Figure("PF", p.sphere->ok(), p.sphere->PF_mm, artefact.mpe.PF_mm));
      p.figures.push_back(Figure("PS", p.sphere->ok(), p.sphere->PS_mm, artefact.mpe.PS_mm));
    }
    if (artefact.ballbar) {
      p.ballbar = EvaluateBallBar(in.cloud, artefact.ballbar->sphere_diameter_mm,
                                  artefact.ballbar->distance_mm, options.vdi);
      p.figures.push_back(Figure("SD", p.ballbar->ok(), p.ballbar->SD_mm, artefact.mpe.SD_mm));
    }
    if (artefact.plane) {
      p.plane = EvaluatePlane(in.cloud, options.vdi);
      p.figures.push_back(Figure("F", p.plane->ok(), p.plane->F_mm, artefact.mpe.F_mm));
    }
    s.positions.push_back(std::move(p));
  }
  // The worst of each figure, and the verdict with the first reason.
  std::vector<std::string> failures, gaps;
  for (const char* name : FigureNames(artefact)) {
    CheckFigure worst = Figure(name, false, 0, MpeOf(artefact, name));
    for (const CheckPosition& p : s.positions) {
      for (const CheckFigure& f : p.figures) {
        if (f.name != name || !f.measured) continue;
        if (!f.pass && f.has_verdict()) {
          failures.push_back(StrCat(name, " = ", Mm(f.value_mm), " mm in ", p.name,
                                    " exceeds the MPE ", Mm(f.mpe_mm), " mm"));
        }
        if (!worst.measured || std::abs(f.value_mm) > std::abs(worst.value_mm)) worst = f;
      }
    }
    if (!worst.measured) {
      gaps.push_back(StrCat(name, " was measured in no position (artefact not found)"));
    } else if (!(worst.mpe_mm > 0)) {
      gaps.push_back(StrCat(name, " has no MPE in the artefact file"));
    }
    s.worst.push_back(worst);
  }
  if (!failures.empty()) {
    s.status = CheckStatus::kFail;
    s.message = failures.front();
    if (failures.size() > 1) s.message += StrCat(" (and ", failures.size() - 1, " more)");
  } else if (!gaps.empty()) {
    s.status = CheckStatus::kIncomplete;
    s.message = gaps.front();
    if (gaps.size() > 1) s.message += StrCat(" (and ", gaps.size() - 1, " more)");
  } else {
    s.status = CheckStatus::kPass;
    s.message = StrCat("every figure within its MPE in ", s.positions.size(), " position",
                       s.positions.size() == 1 ? "" : "s");
  }
  return s;
}

std::string CheckSummary::BriefReport() const {
  std::ostringstream os;
  os << "VDI/VDE 2634-2 check: " << ToString(status) << " (" << message << ")";
  for (const CheckFigure& f : worst) {
    if (f.measured) os << "; worst " << f.name << " " << Mm(f.value_mm) << " mm";
  }
  return os.str();
}

std::string CheckSummary::Table() const {
  std::ostringstream os;
  os << std::left << std::setw(24) << "position";
  for (const CheckFigure& f : worst) {
    os << std::setw(22)
       << StrCat(f.name, f.mpe_mm > 0 ? StrCat(" (MPE ", Mm(f.mpe_mm), ")") : "", ", mm");
  }
  os << "\n";
  for (const CheckPosition& p : positions) {
    os << std::setw(24) << p.name;
    for (const CheckFigure& f : p.figures) os << std::setw(22) << Cell(f);
    os << "\n";
  }
  return os.str();
}

nlohmann::json ToJson(const CheckSummary& s, const Artefact& artefact,
                      const CheckOptions& options) {
  nlohmann::json positions = nlohmann::json::array();
  for (const CheckPosition& p : s.positions) {
    nlohmann::json jp = {{"name", p.name}, {"points", p.points}};
    nlohmann::json figures = nlohmann::json::object();
    for (const CheckFigure& f : p.figures) figures[f.name] = FigureJson(f);
    jp["figures"] = figures;
    if (p.sphere) jp["sphere"] = ToJson(*p.sphere);
    if (p.ballbar) jp["ballbar"] = ToJson(*p.ballbar);
    if (p.plane) jp["plane"] = ToJson(*p.plane);
    positions.push_back(jp);
  }
  nlohmann::json worst = nlohmann::json::object();
  for (const CheckFigure& f : s.worst) worst[f.name] = FigureJson(f);
  const VdiOptions& v = options.vdi;
  return {{"format", "fringe-check"},
          {"version", 1},
          {"status", ToString(s.status)},
          {"passed", s.passed()},
          {"message", s.message},
          {"artefact", ToJson(artefact)},
          {"options",
           {{"discard_fraction", v.discard_fraction},
            {"inlier_band_mm", v.inlier_band_mm},
            {"ransac_iterations", v.ransac_iterations},
            {"seed", v.seed}}},
          {"positions", positions},
          {"worst", worst}};
}

io::Report CheckReport(const CheckSummary& s, const Artefact& artefact) {
  io::Report r;
  r.title = StrCat("VDI/VDE 2634-2 check: ", s.passed() ? "PASS" : ToString(s.status));
  io::ReportSection verdict;
  verdict.title = "Verdict";
  verdict.paragraphs.push_back(s.BriefReport());
  verdict.paragraphs.push_back(
      "A figure passes when PF <= MPE, |PS| <= MPE, |SD| <= MPE, F <= MPE; the certificate's "
      "uncertainties are listed, not subtracted. Up to 0.3 % of each artefact's points are left "
      "out (VDI/VDE 2634-2).");
  io::ReportTable table;
  table.caption = "Figures per position, mm";
  table.header = {"position", "points"};
  for (const CheckFigure& f : s.worst) {
    table.header.push_back(
        StrCat(f.name, f.mpe_mm > 0 ? StrCat(" (MPE ", Mm(f.mpe_mm), ")") : std::string()));
  }
  for (const CheckPosition& p : s.positions) {
    std::vector<std::string> row = {p.name, std::to_string(p.points)};
    for (const CheckFigure& f : p.figures) row.push_back(Cell(f));
    table.rows.push_back(row);
  }
  std::vector<std::string> worst_row = {"worst", ""};
  for (const CheckFigure& f : s.worst) worst_row.push_back(Cell(f));
  table.rows.push_back(worst_row);
  verdict.tables.push_back(table);
  // Ratio to the MPE per position and figure: one bar per cell, the MPE a red line at 1.
  {
    const int rows = static_cast<int>(s.positions.size());
    const int cols = static_cast<int>(s.worst.size());
    const int bar_w = 18, gap = 10, width = std::max(240, 60 + cols * (rows * bar_w + gap)),
              height = 220, top = 20, bottom = height - 40;
    cv::Mat img(height, width, CV_8UC3, cv::Scalar(255, 255, 255));
    double peak = 1.5;
    for (const CheckPosition& p : s.positions) {
      for (const CheckFigure& f : p.figures) {
        if (f.has_verdict()) peak = std::max(peak, std::abs(f.value_mm) / f.mpe_mm * 1.1);
      }
    }
    auto y_of = [&](double ratio) {
      return bottom - static_cast<int>(std::lround(ratio / peak * (bottom - top)));
    };
    for (int c = 0; c < cols; ++c) {
      const int x0 = 50 + c * (rows * bar_w + gap);
      for (int k = 0; k < rows; ++k) {
        const CheckFigure& f = s.positions[size_t(k)].figures[size_t(c)];
        if (!f.has_verdict()) continue;
        const double ratio = std::abs(f.value_mm) / f.mpe_mm;
        cv::rectangle(img, {x0 + k * bar_w, y_of(ratio)}, {x0 + (k + 1) * bar_w - 3, bottom},
                      f.pass ? cv::Scalar(90, 160, 60) : cv::Scalar(40, 40, 210), cv::FILLED);
      }
      cv::putText(img, s.worst[size_t(c)].name, {x0, bottom + 16}, cv::FONT_HERSHEY_SIMPLEX, 0.45,
                  cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
    }
    cv::line(img, {45, y_of(1)}, {width - 5, y_of(1)}, cv::Scalar(0, 0, 220), 1, cv::LINE_AA);
    cv::putText(img, "MPE", {5, y_of(1) + 4}, cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(0, 0, 220),
                1, cv::LINE_AA);
    cv::line(img, {45, bottom}, {width - 5, bottom}, cv::Scalar(0, 0, 0));
    cv::putText(img, "|figure| / MPE per position (green: pass, red: fail)", {5, height - 6},
                cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
    verdict.images.push_back({"Each figure's ratio to its MPE, one bar per position", img});
  }
  r.sections.push_back(verdict);

  io::ReportSection cert;
  cert.title = "Artefact (certificate)";
  if (!artefact.name.empty()) cert.paragraphs.push_back(artefact.name);
  io::ReportTable t;
  t.header = {"artefact", "certified, mm", "uncertainty, mm"};
  if (artefact.sphere) {
    t.rows.push_back(
        {"sphere diameter", Mm(artefact.sphere->diameter_mm), Mm(artefact.sphere->uncertainty_mm)});
  }
  if (artefact.ballbar) {
    t.rows.push_back({"ball-bar centre distance", Mm(artefact.ballbar->distance_mm),
                      Mm(artefact.ballbar->distance_uncertainty_mm)});
    if (artefact.ballbar->sphere_diameter_mm > 0) {
      t.rows.push_back({"ball-bar sphere diameter", Mm(artefact.ballbar->sphere_diameter_mm),
                        Mm(artefact.ballbar->sphere_diameter_uncertainty_mm)});
    }
  }
  if (artefact.plane) {
    t.rows.push_back(
        {"plane flatness", Mm(artefact.plane->flatness_mm), Mm(artefact.plane->uncertainty_mm)});
  }
  cert.tables.push_back(t);
  r.sections.push_back(cert);

  io::ReportSection detail;
  detail.title = "Per position";
  for (const CheckPosition& p : s.positions) {
    std::string text = StrCat(p.name, " (", p.points, " points): ");
    if (p.sphere) text += p.sphere->BriefReport() + "; ";
    if (p.ballbar) text += p.ballbar->BriefReport() + "; ";
    if (p.plane) text += p.plane->BriefReport();
    detail.paragraphs.push_back(text);
  }
  r.sections.push_back(detail);
  return r;
}

}  // namespace fringe::eval
