// The certified artefact of a VDI/VDE 2634-2 acceptance test, read from its artefact file
// (docs/formats.md, "Artefact file"): the calibrated sphere diameter, the ball bar's sphere
// diameter and centre distance, the plane's flatness, each with its certificate uncertainty,
// and the maximum permissible errors (MPE) of PF, PS, SD and F the system is checked against.
//
// One reader for every command that needs the certified figures: `fringe check` (eval/check.h)
// and `fringe refine --artefact` (a known length or diameter holding the rig's scale).
//
// Units: millimetres. Thread safety: plain values; the functions are reentrant.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

namespace fringe::eval {

struct SphereArtefact {
  double diameter_mm = 0;     // calibrated diameter, > 0
  double uncertainty_mm = 0;  // its certificate uncertainty (expanded, as certified), >= 0
};

struct BallBarArtefact {
  double distance_mm = 0;              // calibrated centre distance, > 0
  double distance_uncertainty_mm = 0;  // >= 0
  // Calibrated diameter of its spheres; 0 = not certified (they are then fitted with a free
  // radius, and no PS is measured on them).
  double sphere_diameter_mm = 0;
  double sphere_diameter_uncertainty_mm = 0;  // >= 0
};

struct PlaneArtefact {
  double flatness_mm = 0;     // certified form deviation of the plane, >= 0 (0 = ideal)
  double uncertainty_mm = 0;  // >= 0
};

// Maximum permissible errors; 0 = not specified (a figure measured without its MPE gets no
// verdict: eval/check.h says so).
struct MaxPermissibleErrors {
  double PF_mm = 0;  // probing error, form (range of the sphere's radial residuals)
  double PS_mm = 0;  // probing error, size (|fitted - calibrated diameter|)
  double SD_mm = 0;  // sphere-spacing error (|measured - calibrated distance|)
  double F_mm = 0;   // flatness measurement error (range of distances to the plane)
};

struct Artefact {
  std::string name;  // free text (e.g. the certificate number); may be empty
  std::optional<SphereArtefact> sphere;
  std::optional<BallBarArtefact> ballbar;
  std::optional<PlaneArtefact> plane;
  MaxPermissibleErrors mpe;
};

// Parses an artefact file's JSON; `context` names the source in errors. Throws fringe::Error
// naming the field for an unknown key, a missing or out-of-range value, or a file that
// describes no artefact (none of sphere, ballbar, plane).
Artefact ArtefactFromJson(const nlohmann::json& j, const std::string& context);
// Reads an artefact file (errors name the file and the field).
Artefact ReadArtefact(const std::filesystem::path& path);
// The file's JSON (ArtefactFromJson(ToJson(a)) == a).
nlohmann::json ToJson(const Artefact& a);

}  // namespace fringe::eval
