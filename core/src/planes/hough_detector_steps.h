#pragma once
// The steps of HoughPlaneDetector::detect and the working state they share between frames (the
// detector's Impl): buffers keep their capacity from frame to frame, so steady-state detection
// does not allocate.
//
// The steps, in order:
//  1. sampleFrame: the sample grid and its normals.
//  2. markReliableSamples: samples whose normal agrees with its 4 neighbours (the voters).
//  3. findPlanesByVoting: rounds of Hough voting by the free reliable samples, smoothing, peak
//     picking, and refinement of each peak into a plane that claims its inliers.
//  4. mergeNearDuplicatePlanes: the same plane found twice, merged by a least-squares test.
//     splitTwoFacedPlanes (two_faced_planes.h): a plane whose samples lie on two faces at a
//     crease, split in two.
//  5. fitLeftoverComponents: thin or small surfaces that never voted, fitted per component (a
//     component on two faces, likewise split).
//  6. labelPlanes (plane_labeling.h): full-resolution labels, regions, refits, polygons.

#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "planes/planes_kernels.h"
#include "planes/two_faced_planes.h"
#include "shapesense/core/normals/normals.h"
#include "shapesense/core/planes/hough_accumulator.h"
#include "shapesense/core/planes/plane_labeling.h"
#include "shapesense/core/planes/planes.h"

namespace shapesense {

struct HoughPlaneDetector::Impl {
  explicit Impl(const HoughPlaneParams& p)
      : normals_est(p.normals), raw(p.space), smooth(p.space) {}

  /// Step 1: the sample grid of the frame and the samples' normals; false when the frame has no
  /// sample (narrower than the sample offset).
  bool sampleFrame(const cv::Mat& depth_mm, const CameraIntrinsics& K, const HoughPlaneParams& P);
  /// Step 2: grid.reliable.
  void markReliableSamples(const HoughPlaneParams& P);
  /// Step 3: sample_labels (-1 or the index of the plane that claimed the sample) and the planes.
  std::vector<PlaneHypothesis> findPlanesByVoting(const HoughPlaneParams& P);
  /// Step 5 (after growing the planes found so far over their edges).
  void fitLeftoverComponents(const HoughPlaneParams& P, std::vector<PlaneHypothesis>& planes);

  NormalEstimator normals_est;
  PlaneSampleGrid grid;
  HoughAccumulator raw, smooth;
  cv::Mat sample_labels;

 private:
  // Per-frame constants of the voting rounds.
  struct RoundGates {
    float cos_inlier;      // the normals of a plane's inliers must agree this well
    float min_peak;        // smallest smoothed peak worth refining
    float min_block_mass;  // smoothing skips lighter isolated blocks
    float wide;            // the widest (first) distance gate of a refinement
  };
  RoundGates roundGates(const HoughPlaneParams& P) const;
  // Sizes the per-sample arrays and computes each sample's inlier tolerance.
  void prepareRounds(const HoughPlaneParams& P);
  // Copies the free samples with normals into the free arrays (their count) and the votes of the
  // reliable ones into vx..vd (`votes`).
  int collectFreeSamples(float wide, int& votes);
  // The free samples passing `gates` into cand (indices into the free arrays); their count.
  int scanCandidates(const planes_kernels::PlaneGates& gates, int free_count);
  // The candidates' data, contiguous, for the shrinking passes.
  void gatherCandidates(int num_cand);
  // Refits (n, d) to the candidates with shrinking gates; false when too few remain or a fit
  // fails. alive marks the final set.
  bool refineCandidates(const HoughPlaneParams& P, float cos_inlier, int num_cand,
                        Eigen::Vector3d& n, double& d);
  // The candidates within the tolerance of the refined plane into next; their count.
  int finalInliers(const Eigen::Vector3d& n, double d, float cos_inlier, int num_cand);
  // Refines maximum m of a round; true when it became plane `planes.size()` (appended), which
  // then claims its inliers.
  bool acceptMaximum(const HoughPlaneParams& P, const RoundGates& g, const HoughMaximum& m,
                     int free_count, std::vector<PlaneHypothesis>& planes);
  planes_kernels::SampleArrays freeSamples() const;
  planes_kernels::SampleArrays candidateSamples() const;

  // Structure of arrays of the samples still free in a round (cache-friendly refinement scans).
  // fgate: the widest refinement gate of a free sample, -1 once a plane claims it (so the
  // candidate scan needs no look-up of the label).
  std::vector<int> free_idx;
  std::vector<float> fx, fy, fz, fnx, fny, fnz, ftol, fgate;
  std::vector<std::uint8_t> fin;  // candidate scan: whether a free sample passes the gates
  std::vector<float> sample_tol;  // tolerance of each sample with a normal (by sample index)
  std::vector<int> cand;          // candidates of one maximum (indices into the free arrays)
  std::vector<int> next;  // the accepted plane's final inliers (indices into the free arrays)
  std::vector<std::uint8_t> agree_across, agree_down;  // normal agreement of neighbour pairs
  // The candidates of one maximum, contiguous, and their membership flags (current / next set).
  std::vector<float> cx, cy, cz, cnx, cny, cnz, ctol;
  std::vector<std::uint8_t> calive, cin;
  std::uint8_t* alive_ = nullptr;     // calive or cin: the current set after refineCandidates
  std::uint8_t* spare_ = nullptr;     // the other one
  std::vector<float> vx, vy, vz, vd;  // a round's votes: normal and distance of each
  std::vector<int> comp, seeds;       // leftover components: component of each sample, seeds
};

/// Step 4: merges near-duplicate planes (the same plane found from two maxima or in two rounds,
/// or a thin strip found in pieces) and relabels their samples; merged-away planes stay in
/// `planes` without samples.
void mergeNearDuplicatePlanes(const PlaneSampleGrid& grid, cv::Mat& sample_labels,
                              std::vector<PlaneHypothesis>& planes, const HoughPlaneParams& P);

}  // namespace shapesense
