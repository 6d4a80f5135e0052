#include "shapesense/core/recognition/shape_features.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <numeric>
#include <unordered_map>

#include <Eigen/Eigenvalues>
#include <opencv2/imgproc.hpp>

#include "cloud_index.h"

namespace shapesense {
namespace {

struct Candidate {
  std::uint32_t point = 0;
  float response = 0.0f;
};

// Which points may reach the smallest response. If every normal around a point lies within
// angle t of one axis m, the normals' mean outer product has its largest eigenvalue at least
// cos^2 t (along m) and its smallest at most sin^2 t (across m), so the response is at most
// 2 sin^2 t. The normals' cone is bounded cube by cube (`grid`'s cubes have the response's
// radius as side, so a point's neighbours lie in the 27 cubes around its own), and the points
// of a cube whose surroundings fit in a narrow enough cone are left out: the flat parts of a
// scene, without computing their neighbourhoods and without changing any response that counts.
std::vector<std::uint8_t> mayRespond(const SurfaceCloud& surface, const detail::PointGrid& grid,
                                     float min_response,
                                     const std::vector<std::uint8_t>& may_hold_keypoint) {
  std::vector<std::uint8_t> out = may_hold_keypoint;
  if (out.empty()) out.assign(surface.size(), 1);
  // Half a percent inside the bound, for rounding.
  const float narrow = 0.995f * std::asin(std::sqrt(std::clamp(0.5f * min_response, 0.0f, 1.0f)));
  // Per cube: its normals' axis, and the cosine an axis must exceed to lie within the cone of
  // the smallest response together with the cube's own spread (the largest angle of a normal
  // from its axis, that of the smallest cosine); no axis can when the spread alone fills it.
  std::vector<Eigen::Vector3f> axis(grid.cubeCount(), Eigen::Vector3f::Zero());
  std::vector<float> min_cosine(grid.cubeCount(), 2.0f);
  for (std::size_t c = 0; c < grid.cubeCount(); ++c) {
    grid.forEachPointIn(c, [&](std::uint32_t i) { axis[c] += surface.normals[i]; });
    axis[c].normalize();
    float least_cosine = 1.0f;
    grid.forEachPointIn(c, [&](std::uint32_t i) {
      least_cosine = std::min(least_cosine, surface.normals[i].dot(axis[c]));
    });
    const float spread = std::acos(std::clamp(least_cosine, -1.0f, 1.0f));
    if (spread < narrow) min_cosine[c] = std::cos(narrow - spread);
  }
  grid.forEachCube([&](std::size_t c, const std::vector<std::uint32_t>& around) {
    Eigen::Vector3f common = Eigen::Vector3f::Zero();
    for (std::uint32_t a : around) common += axis[a];
    if (common.norm() < 1e-6f) return;
    common.normalize();
    const bool fits = std::all_of(around.begin(), around.end(), [&](std::uint32_t a) {
      return axis[a].dot(common) > min_cosine[a];
    });
    if (fits) grid.forEachPointIn(c, [&](std::uint32_t i) { out[i] = 0; });
  });
  return out;
}

// Step 1a: the spread of the normals around each allowed point, in point order.
std::vector<Candidate> interestResponses(const SurfaceCloud& surface, const detail::PointGrid& grid,
                                         const ShapeFeatureParams& params,
                                         const std::vector<std::uint8_t>& may_hold_keypoint) {
  // -1: too few neighbours, or a response below min_response for certain.
  std::vector<float> responses(surface.size(), -1.0f);
  const std::vector<std::uint8_t> wanted =
      mayRespond(surface, grid, params.min_response, may_hold_keypoint);
  // Most points mayRespond leaves in still respond below min_response (about 85% on room
  // scenes). The eigenvalues of the normals' mean outer product sum to its trace t, and the
  // largest is at least the squared length of the mean normal m, so the response is at most
  // 1 + t / 2 - 1.5 |m|^2: where that bound falls short (with room for rounding), neither the
  // outer products nor the eigenvalues are needed.
  constexpr float kRoundingRoom = 1e-3f;
  grid.forEachPoint(params.keypoint_radius_m, wanted, [&](std::uint32_t i, const auto& neighbours) {
    if (neighbours.size() < 4) return;
    Eigen::Vector3f normal_sum = Eigen::Vector3f::Zero();
    float squared_lengths = 0.0f;
    for (std::uint32_t j : neighbours) {
      normal_sum += surface.normals[j];
      squared_lengths += surface.normals[j].squaredNorm();
    }
    const float count = static_cast<float>(neighbours.size());
    const float bound =
        1.0f + 0.5f * squared_lengths / count - 1.5f * (normal_sum / count).squaredNorm();
    if (bound < params.min_response - kRoundingRoom) return;
    Eigen::Matrix3f outer = Eigen::Matrix3f::Zero();
    for (std::uint32_t j : neighbours) outer += surface.normals[j] * surface.normals[j].transpose();
    outer /= static_cast<float>(neighbours.size());
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3f> solver;
    solver.computeDirect(outer, Eigen::EigenvaluesOnly);
    const Eigen::Vector3f& eigenvalues = solver.eigenvalues();
    responses[i] = 1.0f - eigenvalues[2] + eigenvalues[0];
  });
  std::vector<Candidate> out;
  for (std::uint32_t i = 0; i < surface.size(); ++i)
    if (responses[i] >= params.min_response) out.push_back({i, responses[i]});
  return out;
}

// Step 1b: the strongest first; a candidate within keypoint_spacing_m of a kept one goes.
std::vector<Candidate> suppressNonMaxima(std::vector<Candidate> candidates,
                                         const SurfaceCloud& surface, float spacing) {
  std::stable_sort(candidates.begin(), candidates.end(),
                   [](const Candidate& a, const Candidate& b) { return a.response > b.response; });
  std::unordered_map<std::int64_t, std::vector<std::uint32_t>> kept_by_cell;
  std::vector<Candidate> kept;
  const float spacing2 = spacing * spacing;
  for (const Candidate& c : candidates) {
    const Eigen::Vector3f& p = surface.points[c.point];
    const Eigen::Vector3i cell = detail::cellOf(p, spacing);
    bool near_kept = false;
    for (int dz = -1; dz <= 1 && !near_kept; ++dz)
      for (int dy = -1; dy <= 1 && !near_kept; ++dy)
        for (int dx = -1; dx <= 1 && !near_kept; ++dx) {
          const auto it = kept_by_cell.find(detail::cellKey(cell + Eigen::Vector3i(dx, dy, dz)));
          if (it == kept_by_cell.end()) continue;
          for (std::uint32_t k : it->second)
            if ((surface.points[k] - p).squaredNorm() < spacing2) near_kept = true;
        }
    if (near_kept) continue;
    kept.push_back(c);
    kept_by_cell[detail::cellKey(cell)].push_back(c.point);
  }
  return kept;
}

// Step 2a: the local plane's normal, the mean of the support's normals: across an edge or a
// corner it stays between the faces' normals for any view that shows them, where the
// covariance's smallest axis swings with how much of each face the view shows.
Eigen::Vector3f localNormal(const SurfaceCloud& surface, const std::vector<std::uint32_t>& support,
                            const Eigen::Vector3f& centre, const Eigen::Vector3f& viewpoint) {
  Eigen::Vector3f normal_sum = Eigen::Vector3f::Zero();
  for (std::uint32_t j : support) normal_sum += surface.normals[j];
  Eigen::Vector3f z = normal_sum.norm() > 1e-6f ? normal_sum.normalized()
                                                : Eigen::Vector3f(viewpoint - centre).normalized();
  if (z.dot(viewpoint - centre) < 0.0f) z = -z;
  return z;
}

// Step 2b: the directions in the local plane that the support's normals lean towards most (the
// downhill directions of its height image). A histogram of the normals' parts in the plane,
// each weighted by its length, smoothed round the circle; every peak of at least
// `peak_ratio` of the highest is a direction (an edge gives its two faces', a corner its three).
// They are set by the surface's own slopes, so they hold for any view that shows them.
constexpr int kLeanBins = 36;
using LeanHistogram = std::array<float, kLeanBins>;

// The normals' parts in the local plane, as (u, v) coordinates, of those that lean at all
// (flatter normals tell no direction).
std::vector<Eigen::Vector2f> normalLeans(const SurfaceCloud& surface,
                                         const std::vector<std::uint32_t>& support,
                                         const Eigen::Vector3f& u, const Eigen::Vector3f& v) {
  constexpr float kMinLean = 0.05f;  // about 3 deg
  std::vector<Eigen::Vector2f> out;
  out.reserve(support.size());
  for (std::uint32_t j : support) {
    const Eigen::Vector2f lean(surface.normals[j].dot(u), surface.normals[j].dot(v));
    if (lean.squaredNorm() >= kMinLean * kMinLean) out.push_back(lean);
  }
  return out;
}

float binsPerRadian() { return kLeanBins / (2.0f * std::numbers::pi_v<float>); }

LeanHistogram leanHistogram(const std::vector<Eigen::Vector2f>& leans) {
  LeanHistogram histogram{};
  for (const Eigen::Vector2f& lean : leans) {
    float position = std::atan2(lean.y(), lean.x()) * binsPerRadian();
    if (position < 0.0f) position += kLeanBins;
    const int whole = static_cast<int>(position);  // position >= 0: its floor
    const int bin = whole % kLeanBins;
    const float frac = position - static_cast<float>(whole);
    const float weight = lean.norm();
    histogram[static_cast<std::size_t>(bin)] += weight * (1.0f - frac);
    histogram[static_cast<std::size_t>((bin + 1) % kLeanBins)] += weight * frac;
  }
  for (int pass = 0; pass < 2; ++pass) {
    LeanHistogram smoothed{};
    for (int i = 0; i < kLeanBins; ++i)
      smoothed[static_cast<std::size_t>(i)] =
          0.25f * histogram[static_cast<std::size_t>((i + kLeanBins - 1) % kLeanBins)] +
          0.5f * histogram[static_cast<std::size_t>(i)] +
          0.25f * histogram[static_cast<std::size_t>((i + 1) % kLeanBins)];
    histogram = smoothed;
  }
  return histogram;
}

// The histogram's peaks of at least `ratio` of the highest, as (height, unit direction), the
// parabola through each peak's bin and its neighbours placing it between them.
std::vector<std::pair<float, Eigen::Vector2f>> histogramPeaks(const LeanHistogram& histogram,
                                                              float ratio) {
  const float highest = *std::max_element(histogram.begin(), histogram.end());
  std::vector<std::pair<float, Eigen::Vector2f>> peaks;
  if (highest <= 0.0f) return peaks;
  for (int i = 0; i < kLeanBins; ++i) {
    const float left = histogram[static_cast<std::size_t>((i + kLeanBins - 1) % kLeanBins)];
    const float here = histogram[static_cast<std::size_t>(i)];
    const float right = histogram[static_cast<std::size_t>((i + 1) % kLeanBins)];
    if (here < ratio * highest || here <= left || here < right) continue;
    const float curvature = left - 2.0f * here + right;
    const float offset = curvature < 0.0f ? 0.5f * (left - right) / curvature : 0.0f;
    const float angle = (static_cast<float>(i) + offset) / binsPerRadian();
    peaks.emplace_back(here, Eigen::Vector2f(std::cos(angle), std::sin(angle)));
  }
  return peaks;
}

// The bins' edges lie where z.unitOrthogonal() puts them, which another view of the same
// surface does not repeat: a peak moves to the mean of the leans within 23 deg of it, which
// depends on the surface alone.
Eigen::Vector2f refinedDirection(Eigen::Vector2f direction,
                                 const std::vector<Eigen::Vector2f>& leans) {
  const float min_cosine = std::cos(0.4f);
  for (int step = 0; step < 2; ++step) {
    Eigen::Vector2f sum = Eigen::Vector2f::Zero();
    for (const Eigen::Vector2f& lean : leans)
      if (lean.dot(direction) >= min_cosine * lean.norm()) sum += lean;
    if (sum.squaredNorm() > 1e-12f) direction = sum.normalized();
  }
  return direction;
}

std::vector<Eigen::Vector3f> leaningDirections(const SurfaceCloud& surface,
                                               const std::vector<std::uint32_t>& support,
                                               const Eigen::Vector3f& z,
                                               const ShapeFeatureParams& params) {
  const Eigen::Vector3f u = z.unitOrthogonal();
  const Eigen::Vector3f v = z.cross(u);
  const std::vector<Eigen::Vector2f> leans = normalLeans(surface, support, u, v);
  auto peaks = histogramPeaks(leanHistogram(leans), params.orientation_peak_ratio);
  std::stable_sort(peaks.begin(), peaks.end(),
                   [](const auto& a, const auto& b) { return a.first > b.first; });
  if (params.max_orientations > 0 &&
      peaks.size() > static_cast<std::size_t>(params.max_orientations))
    peaks.resize(static_cast<std::size_t>(params.max_orientations));
  std::vector<Eigen::Vector3f> out;
  for (const auto& [height, direction] : peaks) {
    const Eigen::Vector2f refined = refinedDirection(direction, leans);
    out.push_back(refined.x() * u + refined.y() * v);
  }
  return out;
}

// Where the normals lean nowhere (a flat patch with an edge of the cloud in it): x points
// towards the support's centroid, cast onto the local plane, its sign the side holding most
// points.
Eigen::Vector3f centroidDirection(const SurfaceCloud& surface,
                                  const std::vector<std::uint32_t>& support,
                                  const Eigen::Vector3f& centre, const Eigen::Vector3f& z) {
  Eigen::Vector3f offset_sum = Eigen::Vector3f::Zero();
  for (std::uint32_t j : support) offset_sum += surface.points[j] - centre;
  Eigen::Vector3f x = offset_sum - offset_sum.dot(z) * z;
  x = x.squaredNorm() > 1e-12f ? x.normalized() : z.unitOrthogonal();
  int positive = 0;
  for (std::uint32_t j : support)
    if ((surface.points[j] - centre).dot(x) >= 0.0f) ++positive;
  if (2 * positive < static_cast<int>(support.size())) x = -x;
  return x;
}

Eigen::Matrix3f frameOf(const Eigen::Vector3f& x, const Eigen::Vector3f& z) {
  Eigen::Matrix3f frame;
  frame.col(0) = x;
  frame.col(1) = z.cross(x);
  frame.col(2) = z;
  return frame;
}

// Step 3, the height image, in two parts (the second only for a support that fills enough of
// the image). The cells' sums and the fill's state, kept across calls to save allocations.
struct HeightImageScratch {
  std::vector<float> sums;
  std::vector<int> counts;
  // The fill's state on a grid with a border of one empty cell, so that every cell has eight
  // neighbours: filled flags (as of the pass before) and heights.
  std::vector<std::uint8_t> filled, next_filled;
  std::vector<float> padded;
  std::vector<int> empty;  ///< padded indices of the cells not filled yet, in raster order
};

// Step 3a: the points' mean height over the local plane per cell (into `scratch`); returns
// the share of cells that held a point.
float rasterise(const SurfaceCloud& surface, const std::vector<std::uint32_t>& support,
                const Eigen::Vector3f& centre, const Eigen::Matrix3f& frame, float radius, int size,
                HeightImageScratch& scratch) {
  const auto cells = static_cast<std::size_t>(size * size);
  scratch.sums.assign(cells, 0.0f);
  scratch.counts.assign(cells, 0);
  const float cell = 2.0f * radius / static_cast<float>(size);
  const Eigen::Matrix3f to_local = frame.transpose();
  for (std::uint32_t j : support) {
    const Eigen::Vector3f local = to_local * (surface.points[j] - centre);
    const int cx = detail::floorToInt((local.x() + radius) / cell);
    const int cy = detail::floorToInt((local.y() + radius) / cell);
    if (cx < 0 || cy < 0 || cx >= size || cy >= size) continue;
    const auto at = static_cast<std::size_t>(cy * size + cx);
    scratch.sums[at] += local.z();
    scratch.counts[at] += 1;
  }
  int held = 0;
  for (std::size_t at = 0; at < cells; ++at) held += scratch.counts[at] > 0;
  return static_cast<float>(held) / static_cast<float>(cells);
}

// Step 3b: empty cells take their filled neighbours' mean, ring by ring, into `heights`.
void fillHeightImage(int size, HeightImageScratch& scratch, cv::Mat& heights) {
  const int stride = size + 2;
  const auto padded_cells = static_cast<std::size_t>(stride * stride);
  scratch.filled.assign(padded_cells, 0);
  scratch.padded.assign(padded_cells, 0.0f);
  scratch.empty.clear();
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) {
      const auto at = static_cast<std::size_t>(y * size + x);
      const int padded_at = (y + 1) * stride + x + 1;
      const int n = scratch.counts[at];
      if (n > 0) {
        scratch.filled[static_cast<std::size_t>(padded_at)] = 1;
        scratch.padded[static_cast<std::size_t>(padded_at)] =
            scratch.sums[at] / static_cast<float>(n);
      } else {
        scratch.empty.push_back(padded_at);
      }
    }
  const int neighbours[8] = {-stride - 1, -stride,    -stride + 1, -1,
                             1,           stride - 1, stride,      stride + 1};
  // A cell filled in a pass is read only from the next one on.
  for (int pass = 0; pass < size && !scratch.empty.empty() &&
                     scratch.empty.size() < static_cast<std::size_t>(size * size);
       ++pass) {
    scratch.next_filled = scratch.filled;
    std::size_t still_empty = 0;
    for (const int at : scratch.empty) {
      float sum = 0.0f;
      int n = 0;
      for (int k = 0; k < 8; ++k) {
        const auto nb = static_cast<std::size_t>(at + neighbours[k]);
        if (!scratch.filled[nb]) continue;
        sum += scratch.padded[nb];
        ++n;
      }
      if (n == 0) {
        scratch.empty[still_empty++] = at;
        continue;
      }
      scratch.padded[static_cast<std::size_t>(at)] = sum / static_cast<float>(n);
      scratch.next_filled[static_cast<std::size_t>(at)] = 1;
    }
    scratch.empty.resize(still_empty);
    scratch.filled.swap(scratch.next_filled);
  }
  heights.create(size, size, CV_32F);
  for (int y = 0; y < size; ++y)
    std::copy_n(scratch.padded.begin() + (y + 1) * stride + 1, size, heights.ptr<float>(y));
}

// Step 4: average pooling to the descriptor's grid, in units of the support radius.
std::array<float, kShapeDescriptorSize> pooledDescriptor(const cv::Mat& heights, float radius) {
  cv::Mat pooled;
  cv::resize(heights, pooled, cv::Size(kShapeDescriptorCells, kShapeDescriptorCells), 0, 0,
             cv::INTER_AREA);
  std::array<float, kShapeDescriptorSize> out{};
  for (int y = 0; y < kShapeDescriptorCells; ++y)
    for (int x = 0; x < kShapeDescriptorCells; ++x)
      out[static_cast<std::size_t>(y * kShapeDescriptorCells + x)] =
          pooled.at<float>(y, x) / radius;
  return out;
}

}  // namespace

std::vector<ShapeFeature> detectShapeFeatures(const SurfaceCloud& surface,
                                              const ShapeFeatureParams& params,
                                              const Eigen::Vector3f& viewpoint,
                                              const std::vector<std::uint8_t>& may_hold_keypoint) {
  CV_Assert(surface.normals.size() == surface.points.size());
  CV_Assert(may_hold_keypoint.empty() || may_hold_keypoint.size() == surface.size());
  CV_Assert(params.support_radius_m > 0.0f && params.keypoint_radius_m > 0.0f &&
            params.height_image_size >= kShapeDescriptorCells);
  if (surface.empty()) return {};
  // Cubes of the response's radius: mayRespond's bound needs that side.
  const detail::PointGrid grid(surface.points, params.keypoint_radius_m);
  const std::vector<Candidate> keypoints =
      suppressNonMaxima(interestResponses(surface, grid, params, may_hold_keypoint), surface,
                        params.keypoint_spacing_m);
  std::vector<ShapeFeature> out;
  std::vector<std::uint32_t> support;
  cv::Mat heights;
  HeightImageScratch scratch;
  for (const Candidate& keypoint : keypoints) {
    const Eigen::Vector3f& centre = surface.points[keypoint.point];
    grid.withinRadius(centre, params.support_radius_m, support);

    if (support.size() < 8) continue;
    const Eigen::Vector3f z = localNormal(surface, support, centre, viewpoint);
    std::vector<Eigen::Vector3f> directions = leaningDirections(surface, support, z, params);
    if (directions.empty()) directions.push_back(centroidDirection(surface, support, centre, z));
    for (const Eigen::Vector3f& x : directions) {
      ShapeFeature feature;
      feature.position = centre;
      feature.response = keypoint.response;
      feature.frame = frameOf(x, z);
      const float filled_share =
          rasterise(surface, support, centre, feature.frame, params.support_radius_m,
                    params.height_image_size, scratch);
      if (filled_share < params.min_filled_share) break;
      fillHeightImage(params.height_image_size, scratch, heights);
      feature.descriptor = pooledDescriptor(heights, params.support_radius_m);
      out.push_back(feature);
    }
    if (params.max_features > 0 && static_cast<int>(out.size()) >= params.max_features) break;
  }
  return out;
}

float descriptorDistance2(const ShapeFeature& a, const ShapeFeature& b) {
  float sum = 0.0f;
  for (std::size_t i = 0; i < a.descriptor.size(); ++i) {
    const float d = a.descriptor[i] - b.descriptor[i];
    sum += d * d;
  }
  return sum;
}

}  // namespace shapesense
