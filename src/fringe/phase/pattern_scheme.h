// Fringe pattern schemes: what the projector shows, in which order, and how to make the images.
//
// Phase convention (docs/conventions.md, "Fringe patterns" in docs/formats.md). Let u be the
// projector coordinate along which the phase varies (the column for vertical fringes, the row for
// horizontal ones; pixel centres at integers) and v = u + 0.5 the same coordinate measured from
// the projector's leading edge. For a phase-shift set with period P (projector pixels, need not be
// an integer) the *absolute phase* is Phi(u) = 2*pi*v / P, and step k shows
//     I_k(u) = mean + amplitude * cos(Phi(u) + phase_offset_rad + shift_k)
// (fractions of full scale; 8-bit images are round(255 * I^(1/gamma)) with gamma the
// pre-compensation). Decoders report absolute phase in projector pixels, u = Phi * P / (2 pi) -
// 0.5.
//
// Gray code (optional, counts the periods of phase set 0): with n bits, column u lies in period
// K = floor(v / P); the n images show the bits of gray(K) most significant first (bright = 1).
// The optional complementary bit is the least significant bit of the (n+1)-bit Gray code of the
// half-period index floor(2 v / P): its stripes switch in the middle of each period, which lets
// the decoder remove the period-edge jumps of plain Gray code (Q. Zhang, X. Su, L. Xiang, X. Sun,
// "3-D shape measurement based on complementary Gray-code light", Opt. Lasers Eng. 50, 2012).
//
// Pure Gray code (no phase set, as SLStudio's and OpenCV's Gray-code codecs): the bits count
// stripes of gray_period_px projector pixels (1 = every column); the decoded coordinate is the
// stripe's centre, (K + 0.5) * gray_period_px - 0.5.
// Inverted Gray images (OpenCV's GrayCodePattern): every Gray image is followed by its inverse,
// and the decoder takes each bit from the pair (bright where the image exceeds its inverse)
// instead of from a threshold.
//
// Image order in a stack: phase set 0 (its N steps), phase set 1, ..., Gray bits (most
// significant first; each followed by its inverse when inverted), complementary bit (and its
// inverse), white frame, dark frame. With reference_frames_first the white and dark frames come
// first instead (SLStudio's Gray code).
//
// 8-bit values: quantization says how the tool turns 255 * I into a byte (fringe rounds half away
// from zero; OpenCV's saturate_cast rounds half to even; SLStudio and SLMaster convert to an
// integer, i.e. truncate). arithmetic = kFloat32 evaluates the phase-shift profile in single
// precision as SLStudio's pstools does, so that truncation hits the same byte: with u the pixel
// index and delta = phase_offset_rad + shift + pi / P (the phase at u = 0),
//     arg = fl(fl(fl(2 pi) * u) / fl(P)) + fl(delta),  I = fl(mean + amplitude * cosf(arg)).
// arithmetic = kFloat32Wrapped is SLMaster's three-frequency generator: the phase is wrapped to
// one period in single precision before the cosine, with d = t - floor(t), t = fl(u / fl(P)),
// and delta' = phase_offset_rad + pi + pi / P + shift (the shift alone for SLMaster's offset),
//     arg = fl(fl((2 d - 1) * pi) + fl(delta')),  I = mean + amplitude * cosf(arg) (double sum).
// A flat step (PhaseShiftSet::flat_steps: no fringe, the 2 + 1 algorithm's third image) shows the
// mean level rounded to the nearest byte (ties to even) whatever the quantization: tools fill it
// with a constant (SLStudio's setTo), not by converting a profile.
//
// Spatial unwrapping (Unwrapping::kSpatial, OpenCV's SinusoidalPattern): one phase set of many
// periods; the wrapped phase (by least squares, by Fourier-transform profilometry from one image,
// or Fourier-assisted phase shifting, PhaseRetrieval) is unwrapped across the camera image by a
// quality-guided flood fill, and each connected region's whole number of periods is fixed by the
// markers the patterns carry (PatternMarkers: OpenCV's crosses, one per period, in the image of
// the set that shows that period's group).
//
// Thread safety: plain value types and pure functions.
#pragma once

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace fringe::phase {

// Vertical fringes: stripes are vertical, the phase varies along projector columns (absolute
// phase is a projector column). Horizontal fringes: the phase varies along projector rows.
enum class FringeDirection { kVertical, kHorizontal };

std::string DirectionName(FringeDirection d);  // "vertical" | "horizontal"

// One frequency of N-step phase shifting.
struct PhaseShiftSet {
  double period_px = 20.0;  // fringe period in projector pixels, > 2 (non-integer allowed)
  int steps = 4;            // N >= 3
  // N phase shifts in radians; empty means the equally spaced 2*pi*k/N.
  std::vector<double> shifts_rad;
  // Constant added to the phase of every step (radians), e.g. -pi when the capture software
  // defines the wrapped phase as -pi at the start of each period.
  double phase_offset_rad = 0.0;
  // Steps whose image shows no fringe, only the mean level (sorted, unique, in [0, steps)): the
  // third image of a 2 + 1 phase shift (Zhang & Yau 2006; SLStudio's PhaseShift2p1). The decoder
  // takes such a step as the background A (design row [1, 0, 0]); at least two steps must carry
  // the fringe. Their shifts are ignored.
  std::vector<int> flat_steps;

  // The shifts actually used (shifts_rad or the equally spaced default).
  std::vector<double> Shifts() const;
  bool IsFlat(int step) const;
};

// Temporal unwrapping (manifest "unwrapping"; Zuo, Huang, Zhang, Chen, Asundi, "Temporal phase
// unwrapping algorithms for fringe projection profilometry: a comparative review", Opt. Lasers
// Eng. 85, 2016):
//  heterodyne        beats of adjacent sets level by level until one covers the span (Reich et
//                    al. 1997; the thesis' scheme); periods increasing, beat of beats >= span.
//  gray              Gray code counts the periods of set 0 (complementary bit optional).
//  hierarchical      multi-frequency: each set is unwrapped by the next coarser one, the coarsest
//                    (period >= span) is absolute on its own; any ratios (1 and 16 periods; 1, 8,
//                    64; ...); periods increasing.
//  number-theoretic  2 or 3 sets whose fringe counts over a common length L (the smallest L
//                    holding a whole number of every period, L >= span) are co-prime as a
//                    tuple: the integer combination f_j c_0 - f_0 c_j of the wrapped phases
//                    (cycles) picks the orders from a table of the segments of [0, L); the
//                    table must have no two segments with one key.
//  spatial           one set of many periods unwrapped across the image (quality-guided flood
//                    fill, spatial_decode.h); each region's period fixed by the patterns' markers.
//  auto (absent)     gray with Gray code, else heterodyne when it fits, else hierarchical.
enum class Unwrapping { kAuto, kHeterodyne, kGray, kHierarchical, kNumberTheoretic, kSpatial };
const char* UnwrappingName(Unwrapping u);  // "auto", "heterodyne", "gray", ...

// How 255 * I becomes a byte (manifest "quantization").
enum class Quantization { kRound, kRoundHalfEven, kFloor };
const char* QuantizationName(Quantization q);  // "round", "round-half-even", "floor"
// Precision of the phase-shift profile (manifest "arithmetic"): "double", "float32" (SLStudio)
// or "float32-wrapped" (SLMaster's three-frequency heterodyne).
enum class Arithmetic { kDouble, kFloat32, kFloat32Wrapped };
const char* ArithmeticName(Arithmetic a);

// How the wrapped phase of set 0 is obtained (manifest "phase_retrieval"; spatial unwrapping
// only, spatial_decode.h):
//  least-squares  the N-step least squares of every pixel (phase-shifting profilometry, PSP)
//  ftp            Fourier-transform profilometry (Takeda, Ina, Kobayashi 1982) of the first
//                 image alone: the spectrum's carrier lobe, band-passed and transformed back
//  faps           Fourier-assisted phase shifting (Cong et al., IEEE J-STSP 9, 2015): each
//                 pixel's actual phase shifts from the FTP phases of the images, then the
//                 least squares with those shifts
enum class PhaseRetrieval { kLeastSquares, kFtp, kFaps };
const char* PhaseRetrievalName(PhaseRetrieval r);

// Markers in the phase-shift images that fix the period of a spatially unwrapped phase
// (manifest "markers"). Layout "opencv": structured_light::SinusoidalPattern's crosses (setMarkers;
// opencv_contrib sinusoidalpattern.cpp): with P = span / periods (integer division), n = periods
// / 3 and m = spacing_px, image i (0..2) of set 0 carries, for j in [0, n) and k in
// [0, (side - first_offset_px) / m), a plus of five pixels of 255 centred on projector coordinate
// c = 3P/4 + j P + i P n - i P/3 (integer arithmetic) along the phase and
// first_offset_px + k m + j (m / n) across it (side: the projector's other dimension). The
// centre lies where image i is darkest; period i n + j carries it.
struct PatternMarkers {
  int spacing_px = 0;        // m (0: no markers)
  int periods = 0;           // OpenCV's nbrOfPeriods (the set's period is span / periods)
  int first_offset_px = 10;  // OpenCV's firstMarkerOffset
  bool Present() const { return spacing_px > 0; }
  // Integer period P and group size n of the layout for a span.
  int Period(int span) const { return periods > 0 ? span / periods : 0; }
  int Group() const { return periods / 3; }
};

// Bounds on what a manifest may ask for (checked before anything is allocated): more sets or
// steps than any real scheme uses only serve to exhaust memory.
inline constexpr size_t kMaxPhaseSets = 16;
inline constexpr int kMaxSteps = 64;

struct PatternScheme {
  std::string name = "custom";
  int projector_width = 1280;  // projector pixels, > 0
  int projector_height = 800;  // projector pixels, > 0
  FringeDirection direction = FringeDirection::kVertical;
  // Phase-shift sets; set 0 is the measuring (finest) frequency. Multi-frequency (heterodyne)
  // unwrapping needs the periods in increasing order with increasing beat periods. Empty only
  // for pure Gray code (gray_bits > 0 and gray_period_px > 0).
  std::vector<PhaseShiftSet> phase_sets;
  Unwrapping unwrapping = Unwrapping::kAuto;  // manifest "unwrapping" (absent: kAuto)
  int gray_bits = 0;                // Gray-code bits counting periods of set 0 (0 = none), <= 16
  bool gray_complementary = false;  // one extra Gray image shifted by half a period
  // Width of the stripes the Gray code counts (projector pixels, >= 1) when there is no phase
  // set; 0 with phase sets (the bits then count periods of set 0).
  double gray_period_px = 0;
  bool gray_inverted = false;           // each Gray image followed by its inverse
  bool reference_frames_first = false;  // white and dark frames before the other images
  Quantization quantization = Quantization::kRound;
  Arithmetic arithmetic = Arithmetic::kDouble;
  PhaseRetrieval phase_retrieval = PhaseRetrieval::kLeastSquares;  // spatial unwrapping only
  PatternMarkers markers;                                          // spatial unwrapping only
  bool white_frame = false;          // a fully lit frame after the Gray code
  bool dark_frame = false;           // a dark frame after that
  double intensity_mean = 0.5;       // pattern mean, fraction of full scale, (0, 1)
  double intensity_amplitude = 0.5;  // pattern amplitude, fraction of full scale, (0, mean] and
                                     // mean + amplitude <= 1
  // Gamma the 8-bit images were pre-compensated for when written (1 = none); informational for
  // decoders, recorded in the manifest.
  double gamma_precompensation = 1.0;
  // File names of the images in stack order (optional; empty = "00.png", "01.png", ...).
  std::vector<std::string> image_names;

  // Number of projector pixels along the phase direction (width for vertical fringes).
  int Span() const {
    return direction == FringeDirection::kVertical ? projector_width : projector_height;
  }
  int NumPhaseImages() const;
  int NumGrayImages() const {
    return (gray_bits + (gray_bits > 0 && gray_complementary ? 1 : 0)) * (gray_inverted ? 2 : 1);
  }
  int NumReferenceImages() const { return (white_frame ? 1 : 0) + (dark_frame ? 1 : 0); }
  int NumImages() const;
  // Index of the first image of phase set s, of Gray bit b (0 = most significant; b == gray_bits
  // is the complementary bit), of its inverse (-1 when not inverted), of the white / dark frame
  // (-1 when absent).
  int PhaseImageIndex(int set) const;
  int GrayImageIndex(int bit) const;
  int GrayInverseIndex(int bit) const;
  int WhiteImageIndex() const;
  int DarkImageIndex() const;
  // image_names or the default names.
  std::vector<std::string> ImageNames() const;
  // The width the Gray code counts: period of set 0, or gray_period_px for pure Gray code.
  double GrayPeriod() const {
    return phase_sets.empty() ? gray_period_px : phase_sets[0].period_px;
  }
  // The 8-bit value of intensity `linear` in [0, 1] after pre-compensation for `gamma`, as the
  // scheme's quantization makes it.
  uint8_t Quantize(double linear, double gamma = 1.0) const;

  // Why heterodyne unwrapping does not fit the sets ("" when it does).
  std::string HeterodyneMisfit() const;
  // The method the decoder uses: unwrapping, or for kAuto the one that fits (see Unwrapping).
  Unwrapping Method() const;

  // Throws fringe::Error naming the field when the scheme is inconsistent (no phase set, N < 3,
  // shifts that do not determine the phase, too few Gray bits to count the periods, ...).
  void Check() const;
};

// The table of number-theoretic unwrapping (Unwrapping::kNumberTheoretic): fringe counts of the
// sets over the common length, and for every key (m_1, ..., m_{n-1}), m_j = f_j k_0 - f_0 k_j,
// the order k_0 of set 0 (-1 where no position of [0, L) has that key).
struct NumberTheoreticTable {
  double length_px = 0;      // L
  std::vector<int> counts;   // f_s = L / P_s
  std::vector<int> key_min;  // per j = 1..n-1
  std::vector<int> key_size;
  std::vector<int> k0;  // dense, key_size[0] * key_size[1] * ...
  // k_0 for rounded keys m[0..n-2], or -1.
  int Lookup(const int* m) const;
};
// The markers of a scheme (PatternMarkers), in the order they are drawn: the image (index in the
// stack), the period that carries the marker, its centre along the phase direction (projector
// pixel index) and across it. Empty without markers.
struct MarkerPosition {
  int image = 0;
  int period = 0;
  int u = 0;
  int across = 0;
};
std::vector<MarkerPosition> MarkerPositions(const PatternScheme& scheme);

// Throws fringe::Error naming "<context>.unwrapping" when the sets do not fit the method (count
// of sets, no common length within 4096 periods of the coarsest set, L < span, two segments with
// one key).
NumberTheoreticTable MakeNumberTheoreticTable(const PatternScheme& scheme,
                                              const std::string& context = "scheme");

// Presets (projector size in pixels):
//  "heterodyne-4x3"  three frequencies x 4 steps (12 images); periods L/70, L/64, L/59 with
//                    L = 1.25 * span, so the beat of beats (period L) covers the whole projector
//                    with margin and the beats have periods L/6 and L/5.
//  "thesis-4+3+3"    the same three periods, 4 steps on the fine measuring frequency and 3 steps
//                    on the two coarse unwrapping frequencies (10 images).
//  "heterodyne-3x3"  three frequencies x 3 steps (9 images).
//  "gray+4"          4-step phase shift with period span / 2^n, n the fewest Gray bits that make
//                    the period <= 32 px, + complementary Gray code (4 + n + 1 images).
//  "slsdk-phasegray" the capture in ../shared/data/slsdk-stereo-phasegray: 1920x1080 projector,
//                    4-step period 60 px with offset -pi, 5 Gray bits + complementary, images
//                    0.png ... 9.png (size arguments ignored).
PatternScheme MakeScheme(const std::string& preset, int projector_width = 1280,
                         int projector_height = 800);
std::vector<std::string> SchemePresetNames();

// Manifest (docs/formats.md, "Pattern scheme manifest").
nlohmann::json SchemeToJson(const PatternScheme& scheme);
// `context` names the source for errors ("manifest.json"). The result is Check()ed.
PatternScheme SchemeFromJson(const nlohmann::json& j, const std::string& context);
PatternScheme ReadScheme(const std::filesystem::path& path);
void WriteScheme(const std::filesystem::path& path, const PatternScheme& scheme);
// A preset name or a manifest file path.
PatternScheme SchemeFromNameOrFile(const std::string& name_or_path, int projector_width = 1280,
                                   int projector_height = 800);

// Projector images (CV_8UC1, projector_height x projector_width) in the scheme's image order.
// precompensate_gamma > 0: each value is round(255 * I^(1 / gamma)) so that a projector with
// response out = in^gamma shows the intended sinusoid.
std::vector<cv::Mat> GeneratePatterns(const PatternScheme& scheme,
                                      double precompensate_gamma = 1.0);

// The ideal (continuous, linear) intensity in [0, 1] of image `index` at projector coordinate u
// along the phase direction. Used by GeneratePatterns and by renderers that want the pattern
// without 8-bit quantisation.
double PatternIntensity(const PatternScheme& scheme, int index, double u);

// Writes the patterns as 8-bit PNGs plus "manifest.json" (the scheme with its image names and
// gamma_precompensation) into `dir`, atomically (the folder appears complete or not at all).
void WritePatternFolder(const std::filesystem::path& dir, const PatternScheme& scheme,
                        double precompensate_gamma = 1.0);

}  // namespace fringe::phase
