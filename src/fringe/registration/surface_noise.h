// A view's measurement noise from local plane fits, for tolerances that follow the data (the
// marker-free verification, register_views.cc) rather than a pair's ICP residual, which is
// large exactly when the pair is wrong.
//
// At `samples` seeded random points, the `neighbours` nearest points (a k-d tree: organized or
// not) are fitted with a plane (PCA); the RMS distance from it, corrected for the three fitted
// degrees of freedom, is that neighbourhood's noise; the median over the samples is returned,
// so that edges and creases (where no plane fits) do not count. On a curved surface the plane's
// misfit adds (for a radius of curvature R and a neighbourhood of radius r, about
// r^2 / (4 sqrt(3) R)): it is an upper bound there.
//
// Frames and units: the cloud's; mm. Thread safety: reentrant; deterministic for a seed.
#pragma once

#include <cstdint>

#include "fringe/geometry/point_cloud.h"

namespace fringe::registration {

// 0 for a cloud with fewer than `neighbours` finite points. neighbours >= 4, samples >= 1 (else
// fringe::Error).
double EstimateSurfaceNoiseMm(const PointCloud& cloud, int samples = 1000, int neighbours = 16,
                              uint64_t seed = 1);

}  // namespace fringe::registration
