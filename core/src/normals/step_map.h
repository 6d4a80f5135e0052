#pragma once
// The depth-step map of the normal estimators: where the surface breaks, and how far every pixel
// is from such a break, so that no window straddles one. Internal to core/src/normals/.

#include "normals/normal_workspace.h"
#include "shapesense/core/normals/normals.h"

namespace shapesense::detail {

/// Marks depth steps into steps.marks: between neighbouring valid pixels, and across runs of up
/// to params.max_gap_px invalid pixels (Kinect shadows), the depth change exceeds
/// max(factor * z * (gap + 1), noise_steps * depthStep(z)). Only one pixel of each step pair is
/// marked (left / top): every square window holding pixels of both sides holds a 4-adjacent
/// pair across the step, hence a mark, so "no mark in the window" is exactly "the window does
/// not straddle a step".
void markDepthSteps(const NormalParams& params, const NormalInput& input, StepMap& steps);

/// Chessboard distance from every pixel to the nearest step mark, capped at `cap`, into
/// steps.distance: the square window of radius R centred on a pixel holds no mark iff
/// R < distance, so one lookup replaces shrinking the window through the integral image.
void computeStepDistance(int cap, StepMap& steps);

}  // namespace shapesense::detail
