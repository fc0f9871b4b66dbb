// Single-frequency fringe analysis with spatial unwrapping (Unwrapping::kSpatial): OpenCV
// contrib's structured_light::SinusoidalPattern (PSP, FTP, FAPS), whose patterns carry many
// periods of one frequency and no temporal cue.
//
//  1. Fourier analysis of every image of the set (Takeda, Ina, Kobayashi, "Fourier-transform
//     method of fringe-pattern analysis for computer-based topography and interferometry",
//     JOSA 72, 1982): the 2D spectrum of the mean-free image, its carrier (the strongest peak
//     away from DC), a Hann window of radius |carrier| / 2 around the carrier and around DC; the
//     inverse transforms give the analytic signal z = (B / 2) exp(+-i phi) and the band-limited
//     image (DC + both carrier lobes). The sign of the carrier lobe is fixed by the phase step
//     from the first image to the second (the scheme's shifts), so phi increases with the
//     projector coordinate.
//  2. Markers (PatternMarkers): bright pluses where their image is darkest. A pixel belongs to a
//     marker when its image exceeds the band-limited image by more than the local modulation B
//     while no other image of the set does; connected pixels form one marker, its image tells
//     the group of periods (i n ... i n + n - 1) it lies in. Marker pixels (and their
//     neighbours) are rejected (reason spatial): they break every image model.
//  3. Wrapped phase by the scheme's PhaseRetrieval: least squares over the N images (PSP); the
//     first image's analytic signal (FTP); or the least squares with each pixel's own shifts,
//     taken from the analytic signals' phase differences (FAPS, Cong et al. 2015).
//  4. Quality-guided unwrapping (flood fill from the pixel of highest modulation, always to the
//     valid neighbour of highest modulation; a step of more than max_order_residual cycles
//     between neighbours is not crossed), giving connected regions, each known up to a whole
//     number K of periods.
//  5. Each region's K from its markers: a marker of image i seen at relative phase c fixes
//     K - j = round((c_0(i) + 0.5) / P - c) for its unknown j in [0, n) (c_0 the layout's first
//     marker column of image i); the K consistent with every marker of the region and keeping the
//     region inside the projector is taken when it is unique, else the region is rejected as
//     ambiguous. Regions under kMinRegionPixels are rejected (spatial).
//
// Thread safety: reentrant; TBB over rows for the per-pixel steps.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

#include "fringe/phase/decode.h"
#include "fringe/phase/pattern_scheme.h"

namespace fringe::phase {

// Rounds of fringe continuation before the Fourier analysis (FourierAnalysis): fewer leave more
// of the edge leakage, more start to amplify noise where the extrapolation is long (corners).
constexpr int kFringeContinuationIterations = 8;

// Smallest connected region of valid pixels that is kept.
constexpr int kMinRegionPixels = 64;

// Fourier-transform profilometry of one image (CV_32F): the analytic signal of the carrier lobe
// (CV_32FC2, (B / 2) exp(i phi) with phi increasing along `carrier`), the band-limited image
// (CV_32F: DC and both carrier lobes) and the carrier (cycles per pixel, x right, y down).
struct FourierFringe {
  cv::Mat analytic;
  cv::Mat band_limited;
  cv::Point2d carrier;
};

// The carrier of a fringe image (CV_32F): the strongest peak of its spectrum at least
// 3 / min(width, height) cycles per pixel from DC, on the side where its larger component is
// positive.
cv::Point2d FindCarrier(const cv::Mat& image);

// FTP of `image` (CV_32F) around `carrier` (FindCarrier): Hann windows of radius |carrier| / 2.
// With iterations > 0 the fringe is first continued past the image's border and into the pixels
// `known` (CV_8U, empty: every pixel) leaves out, by that many rounds of Gerchberg-Papoulis
// extrapolation within the band (DC and both lobes): without it the cut fringe leaks the opposite
// lobe into the analytic signal near edges (a phase error of ~0.1 rad within a period of them).
FourierFringe FourierAnalysis(const cv::Mat& image, cv::Point2d carrier,
                              const cv::Mat& known = cv::Mat(), int iterations = 0);

// Quality-guided spatial unwrapping of `cycles` (CV_32F, the wrapped phase in cycles, [0, 1))
// over `valid` (CV_8U, non-zero valid): *unwrapped (CV_32F cycles, NaN where not valid) and
// *labels (CV_32S, region index from 0, -1 where not valid); returns the number of regions.
// A step between neighbours of more than max_step cycles (in (0, 0.5]) is not crossed.
int UnwrapQualityGuided(const cv::Mat& cycles, const cv::Mat& quality, const cv::Mat& valid,
                        double max_step, cv::Mat* unwrapped, cv::Mat* labels);

// One marker found in a capture: its image (index in the stack), centroid (camera pixels) and
// pixel count.
struct FoundMarker {
  int image = 0;
  cv::Point2d centre;
  int pixels = 0;
};

// Decode of a scheme with Unwrapping::kSpatial (decode.h's Decode calls it); full_scale_dn as
// there. The summary's message reports the markers found and the regions anchored.
void DecodeSpatial(const PatternScheme& scheme, const std::vector<cv::Mat>& images,
                   const DecodeOptions& options, double full_scale_dn, DecodeResult* result,
                   std::vector<FoundMarker>* markers = nullptr);

}  // namespace fringe::phase
