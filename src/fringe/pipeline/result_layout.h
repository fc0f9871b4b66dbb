// Where everything lives in a scan's output folder (OUT of `fringe scan`, and the parts of it
// that `fringe register`, `fringe fuse` and `fringe check` write or read): the twin of
// scan::ScanLayout for the input side. Nothing is read or checked. docs/scan-folder.md
// describes each file.
#pragma once

#include <filesystem>
#include <string>

namespace fringe::pipeline {

struct ResultLayout {
  std::filesystem::path root;

  // The rig used (with the calibration figures when calibrated here).
  std::filesystem::path Rig() const { return root / "rig.json"; }
  // The calibration report of a rig calibrated here (calib::WriteCalibrationReport).
  std::filesystem::path CalibrationDir() const { return root / "calibration"; }
  std::filesystem::path ViewsDir() const { return root / "views"; }
  // A view's organized cloud, sensor frame.
  std::filesystem::path ViewCloud(const std::string& view) const {
    return ViewsDir() / (view + ".ply");
  }
  // A view's sticky markers, sensor frame (registration::WriteViewMarkers).
  std::filesystem::path ViewMarkers(const std::string& view) const {
    return ViewsDir() / (view + ".markers.json");
  }
  std::filesystem::path Poses() const { return root / "poses.json"; }
  std::filesystem::path MarkerMap() const { return root / "markers.json"; }
  std::filesystem::path RegisteredDir() const { return root / "registered"; }
  // A registered view's organized cloud, world frame.
  std::filesystem::path RegisteredCloud(const std::string& view) const {
    return RegisteredDir() / (view + ".ply");
  }
  std::filesystem::path Fused() const { return root / "fused.ply"; }
  std::filesystem::path Mesh() const { return root / "mesh.ply"; }
  std::filesystem::path MeshStl() const { return root / "mesh.stl"; }
  std::filesystem::path Summary() const { return root / "summary.json"; }
  std::filesystem::path Report() const { return root / "report.html"; }
};

}  // namespace fringe::pipeline
