// The virtual scanner in one include: scenes (scene.h, demo_part.h, markers.h), ray casting
// (ray_caster.h), fringe rendering with ground truth (renderer.h), calibration boards (board.h),
// poses (poses.h) and scan folders (scan.h; docs/scan-folder.md).
//
// Typical use in a test:
//   const StereoRig rig = sim::ScaledRig(StereoRig::Reference(), 0.25);  // 320x256, fast
//   const sim::Renderer renderer(sim::MakeDemoPart(), rig);
//   const Rigid3d world_from_sensor = sim::OrbitPoses(rig, {0, 0, 25})[0];
//   const sim::ViewImages view = renderer.RenderView(world_from_sensor, patterns);
//   // view.left.images[k], view.left.truth.{depth, points, normals, projector, valid},
//   // view.markers[i].{left_px, right_px, visible_left, visible_right}
#pragma once

#include "fringe/sim/board.h"
#include "fringe/sim/demo_part.h"
#include "fringe/sim/markers.h"
#include "fringe/sim/poses.h"
#include "fringe/sim/ray_caster.h"
#include "fringe/sim/renderer.h"
#include "fringe/sim/scan.h"
#include "fringe/sim/scene.h"
