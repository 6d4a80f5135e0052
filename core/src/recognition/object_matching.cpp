#include "shapesense/core/recognition/object_matching.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <numbers>
#include <optional>
#include <unordered_map>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>

#include "shapesense/core/planes/planes.h"
#include "shapesense/core/recognition/flat_faces.h"

#include "cloud_index.h"
#include "descriptor_kernels.h"
#include "icp_step.h"

namespace shapesense {
namespace {

// A model feature matched to a scene feature, with what the steps after read of both.
struct Match {
  Eigen::Vector3f model_point;  ///< the model feature's position
  Eigen::Vector3f scene_point;  ///< the scene feature's position
  /// The rotation carrying the model feature's local frame onto the scene feature's: with the
  /// two points, the whole pose the match gives.
  Eigen::Matrix3f turn;
  int scene = 0;           ///< index into the scene's features
  int model_keypoint = 0;  ///< the model's interest point it was described at
};

// The interest point of each feature: the features of one point follow each other with the
// same position (one per local frame, shape_features.h).
std::vector<int> keypointOfFeature(const std::vector<ShapeFeature>& features) {
  std::vector<int> out(features.size(), 0);
  for (std::size_t i = 1; i < features.size(); ++i)
    out[i] = out[i - 1] + (features[i].position == features[i - 1].position ? 0 : 1);
  return out;
}

// The `k` nearest of `distances` (squared) into `out`, nearest first, equal ones in index
// order; `kept` holds their distances. By insertion: after the first k, nearly every distance
// is rejected by one comparison, which measured faster than std::partial_sort and
// std::nth_element over the indices (45 against 46 and 50 ms for five models).
void nearestIndices(const float* distances, std::size_t count, int k, std::vector<int>& out,
                    std::vector<float>& kept) {
  out.clear();
  kept.clear();
  const auto wanted = static_cast<std::size_t>(std::max(0, k));
  if (wanted == 0) return;
  for (std::size_t j = 0; j < count; ++j) {
    const float d = distances[j];
    if (out.size() == wanted && !(d < kept.back())) continue;
    if (out.size() < wanted) {
      out.push_back(0);
      kept.push_back(0.0f);
    }
    std::size_t at = out.size() - 1;
    for (; at > 0 && kept[at - 1] > d; --at) {
      kept[at] = kept[at - 1];
      out[at] = out[at - 1];
    }
    kept[at] = d;
    out[at] = static_cast<int>(j);
  }
}

// Step 1.
std::vector<Match> candidateMatches(const ObjectModel& model, const SceneSurface& scene,
                                    const ObjectMatchParams& params) {
  const std::vector<ShapeFeature>& found = scene.features();
  if (model.features.empty() || found.empty()) return {};
  const std::vector<int> keypoint = keypointOfFeature(model.features);
  std::vector<const float*> queries(model.features.size());
  for (std::size_t i = 0; i < queries.size(); ++i) queries[i] = model.features[i].descriptor.data();
  std::vector<float> distances(queries.size() * found.size());
  detail::squaredDistancesToAll(queries.data(), queries.size(), scene.descriptorColumns().data(),
                                found.size(), distances.data());
  std::vector<int> nearest;
  std::vector<float> nearest_distances;
  std::vector<Match> out;
  for (std::size_t i = 0; i < model.features.size(); ++i) {
    const ShapeFeature& from = model.features[i];
    nearestIndices(distances.data() + i * found.size(), found.size(), params.matches_per_feature,
                   nearest, nearest_distances);
    for (const int j : nearest) {
      const ShapeFeature& to = found[static_cast<std::size_t>(j)];
      out.push_back(
          {from.position, to.position, to.frame * from.frame.transpose(), j, keypoint[i]});
    }
  }
  return out;
}

// Where a pose hypothesis comes from: fitted to feature matches, laid by flat faces
// (flat_faces.h), or laid by the model's box on a cluster's (surface_clusters.h).
enum class PoseSource { kFeatures, kFlatFaces, kCluster, kStanding };

struct Hypothesis {
  Eigen::Isometry3f scene_from_model = Eigen::Isometry3f::Identity();
  int inliers = 0;
  PoseSource source = PoseSource::kFeatures;
  /// `inliers` counted (poses laid by geometry alone count theirs once verified).
  bool inliers_counted = true;
};

// The rigid motion that best carries the model points of `matches[i]` (i in `chosen`) onto their
// scene points. In double: the float version trips GCC 12's array-bounds warning inside Eigen,
// and the solve is cheap either way.
Eigen::Isometry3f fittedPose(const std::vector<Match>& matches,
                             const std::vector<std::uint32_t>& chosen) {
  Eigen::Matrix3Xd model_points(3, static_cast<Eigen::Index>(chosen.size()));
  Eigen::Matrix3Xd scene_points(3, static_cast<Eigen::Index>(chosen.size()));
  for (std::size_t i = 0; i < chosen.size(); ++i) {
    model_points.col(static_cast<Eigen::Index>(i)) = matches[chosen[i]].model_point.cast<double>();
    scene_points.col(static_cast<Eigen::Index>(i)) = matches[chosen[i]].scene_point.cast<double>();
  }
  const Eigen::Matrix4d transform = Eigen::umeyama(model_points, scene_points, false);
  return Eigen::Isometry3f(transform.cast<float>());
}

// The matches that agree with a pose, one per model interest point (the closest). `matches`
// come in the model's feature order (candidateMatches), so the last holds the last point.
std::vector<std::uint32_t> agreeingMatches(const Eigen::Isometry3f& pose,
                                           const std::vector<Match>& matches,
                                           float inlier_distance) {
  const std::size_t keypoints = matches.empty() ? 0 : matches.back().model_keypoint + 1u;
  std::vector<float> best(keypoints, inlier_distance * inlier_distance);
  std::vector<int> chosen(keypoints, -1);
  // The matches of one interest point follow each other: it is posed once for all of them.
  Eigen::Vector3f posed = Eigen::Vector3f::Zero();
  int posed_keypoint = -1;
  for (std::size_t i = 0; i < matches.size(); ++i) {
    const Match& m = matches[i];
    if (m.model_keypoint != posed_keypoint) {
      posed = pose * m.model_point;
      posed_keypoint = m.model_keypoint;
    }
    const float d2 = (posed - m.scene_point).squaredNorm();
    const auto k = static_cast<std::size_t>(m.model_keypoint);
    if (d2 < best[k]) {
      best[k] = d2;
      chosen[k] = static_cast<int>(i);
    }
  }
  std::vector<std::uint32_t> out;
  for (int c : chosen)
    if (c >= 0) out.push_back(static_cast<std::uint32_t>(c));
  return out;
}

bool samePose(const Eigen::Isometry3f& a, const Eigen::Isometry3f& b,
              const Eigen::Vector3f& centre) {
  constexpr float kDistanceM = 0.02f;
  constexpr float kAngleRad = 0.17f;  // 10 deg
  const Eigen::AngleAxisf turn(a.linear() * b.linear().transpose());
  return (a * centre - b * centre).norm() < kDistanceM && std::abs(turn.angle()) < kAngleRad;
}

// Keeps the `capacity` hypotheses with the most inliers, one per distinct pose.
void keepHypothesis(std::vector<Hypothesis>& kept, const Hypothesis& candidate,
                    std::size_t capacity, const Eigen::Vector3f& centre) {
  for (Hypothesis& h : kept) {
    if (!samePose(h.scene_from_model, candidate.scene_from_model, centre)) continue;
    if (candidate.inliers > h.inliers) h = candidate;
    std::sort(kept.begin(), kept.end(),
              [](const Hypothesis& x, const Hypothesis& y) { return x.inliers > y.inliers; });
    return;
  }
  if (kept.size() < capacity) {
    kept.push_back(candidate);
  } else if (candidate.inliers > kept.back().inliers) {
    kept.back() = candidate;
  } else {
    return;
  }
  std::sort(kept.begin(), kept.end(),
            [](const Hypothesis& x, const Hypothesis& y) { return x.inliers > y.inliers; });
}

// The pose fitted to every match that agrees with `h`.
Hypothesis refitOnAgreeing(const Hypothesis& h, const std::vector<Match>& matches,
                           const ObjectMatchParams& params) {
  return Hypothesis{
      fittedPose(matches, agreeingMatches(h.scene_from_model, matches, params.inlier_distance_m)),
      h.inliers, PoseSource::kFeatures, true};
}

// Where a turn sends the model's x and y axes (its first two columns), each coordinate binned
// on a grid of `side`. Two turns within angle t of each other send every axis to within the
// chord 2 sin(t / 2) of each other, so with `side` at least that chord their bins differ by at
// most one in every coordinate.
using TurnBins = std::array<std::int16_t, 6>;

TurnBins turnBins(const Eigen::Matrix3f& turn, float side) {
  TurnBins out{};
  for (int k = 0; k < 6; ++k)
    out[static_cast<std::size_t>(k)] =
        static_cast<std::int16_t>(detail::floorToInt((turn(k % 3, k / 3) + 1.0f) / side));
  return out;
}

bool neighbouringBins(const TurnBins& a, const TurnBins& b) {
  for (std::size_t k = 0; k < a.size(); ++k)
    if (std::abs(a[k] - b[k]) > 1) return false;
  return true;
}

// Pairs of matches that a rigid motion could carry together: they turn the model alike, their
// model points and their scene points lie equally far apart (and far enough apart to fix a
// rotation), and they share neither feature. Two such matches put the model's centre near each
// other: their turns differ by at most max_frame_disagreement_deg, which parts the centres they
// give by about 2 sin(angle / 2) times the model's reach, plus the pair tolerance. So only
// matches in neighbouring cubes of that side, and within those in neighbouring turn bins, are
// compared.
std::vector<std::vector<std::uint32_t>> compatiblePairs(const std::vector<Match>& matches,
                                                        const ObjectModel& model,
                                                        const ObjectMatchParams& params) {
  const float min_spacing2 = params.min_sample_spacing_m * params.min_sample_spacing_m;
  const float tolerance2 = params.pair_tolerance_m * params.pair_tolerance_m;
  const float max_angle = params.max_frame_disagreement_deg * std::numbers::pi_v<float> / 180.0f;
  const float min_trace = 1.0f + 2.0f * std::cos(max_angle);
  // The reach of the features (the matched points), not of the model's surface.
  float reach2 = 0.0f;
  for (const ShapeFeature& f : model.features)
    reach2 = std::max(reach2, (f.position - model.box.centre).squaredNorm());
  const float chord = 2.0f * std::sin(0.5f * std::min(max_angle, std::numbers::pi_v<float>));
  const float cube = params.pair_tolerance_m + chord * std::sqrt(reach2);
  // A little over the chord, for rounding; at most 1000 bins a coordinate.
  const float turn_side = std::max(1.01f * chord, 0.002f);
  struct Group {
    TurnBins bins;
    std::vector<std::uint32_t> members;
  };
  struct Cube {
    Eigen::Vector3i cell;
    std::vector<Group> groups;
  };
  std::unordered_map<std::int64_t, Cube> by_cube;
  for (std::uint32_t i = 0; i < matches.size(); ++i) {
    const Match& m = matches[i];
    const Eigen::Vector3i cell =
        detail::cellOf(m.turn * (model.box.centre - m.model_point) + m.scene_point, cube);
    Cube& c = by_cube[detail::cellKey(cell)];
    c.cell = cell;
    const TurnBins bins = turnBins(m.turn, turn_side);
    auto group = std::find_if(c.groups.begin(), c.groups.end(),
                              [&](const Group& g) { return g.bins == bins; });
    if (group == c.groups.end()) group = c.groups.insert(c.groups.end(), Group{bins, {}});
    group->members.push_back(i);
  }
  std::vector<std::vector<std::uint32_t>> out(matches.size());
  const auto compare = [&](std::uint32_t a, std::uint32_t b) {
    const Match& ma = matches[a];
    const Match& mb = matches[b];
    if (ma.model_keypoint == mb.model_keypoint || ma.scene == mb.scene) return;
    const float dm2 = (mb.model_point - ma.model_point).squaredNorm();
    if (dm2 < min_spacing2) return;
    const float ds2 = (mb.scene_point - ma.scene_point).squaredNorm();
    // Most compared pairs fail this test. Since |dm - ds| (dm + ds) = |dm2 - ds2| and
    // dm + ds <= sqrt(2 (dm2 + ds2)), those whose squares differ by enough go without a square
    // root (2% to spare for rounding); the exact test follows.
    const float gap2 = (dm2 - ds2) * (dm2 - ds2);
    if (gap2 > 2.04f * tolerance2 * (dm2 + ds2)) return;
    if (std::abs(std::sqrt(dm2) - std::sqrt(ds2)) > params.pair_tolerance_m) return;
    // trace(A^T B): 1 + 2 cos of the turn between them.
    if (ma.turn.cwiseProduct(mb.turn).sum() < min_trace) return;
    out[a].push_back(b);
    out[b].push_back(a);
  };
  const auto compareGroups = [&](const Group& g, const Group& h) {
    if (!neighbouringBins(g.bins, h.bins)) return;
    for (std::uint32_t a : g.members)
      for (std::uint32_t b : h.members) compare(a, b);
  };
  // Each pair of neighbouring cubes once: a cube with itself, and with the 13 of its 26
  // neighbours that come after it in (z, y, x) order.
  for (const auto& [key, c] : by_cube) {
    for (std::size_t g = 0; g < c.groups.size(); ++g) {
      const std::vector<std::uint32_t>& members = c.groups[g].members;
      for (std::size_t i = 0; i < members.size(); ++i)
        for (std::size_t j = i + 1; j < members.size(); ++j) compare(members[i], members[j]);
      for (std::size_t h = g + 1; h < c.groups.size(); ++h) compareGroups(c.groups[g], c.groups[h]);
    }
    for (int dz = 0; dz <= 1; ++dz)
      for (int dy = dz == 0 ? 0 : -1; dy <= 1; ++dy)
        for (int dx = (dz == 0 && dy == 0) ? 1 : -1; dx <= 1; ++dx) {
          const auto it = by_cube.find(detail::cellKey(c.cell + Eigen::Vector3i(dx, dy, dz)));
          if (it == by_cube.end()) continue;
          for (const Group& g : c.groups)
            for (const Group& h : it->second.groups) compareGroups(g, h);
        }
  }
  for (auto& partners : out) std::sort(partners.begin(), partners.end());
  return out;
}

// Step 2: each match gives a whole pose (shape_features.h's frames repeat across views). The
// matches with the most compatible partners anchor poses in turn: the anchor's own pose picks
// the partners it agrees with, a pose is fitted to them, and the matches that agree with that
// score it. The distinct poses the most model features agree with are kept, best first: the
// most agreed-on pose is often a box turned half round (its corners look alike), which only
// the depth check tells from the right one.
std::vector<Hypothesis> anchoredPoses(const std::vector<Match>& matches, const ObjectModel& model,
                                      const ObjectMatchParams& params) {
  const std::vector<std::vector<std::uint32_t>> partners = compatiblePairs(matches, model, params);
  std::vector<std::uint32_t> anchors;
  for (std::uint32_t i = 0; i < matches.size(); ++i)
    if (static_cast<int>(partners[i].size()) + 1 >= params.min_inliers) anchors.push_back(i);
  std::stable_sort(anchors.begin(), anchors.end(), [&](std::uint32_t a, std::uint32_t b) {
    return partners[a].size() > partners[b].size();
  });
  if (anchors.size() > static_cast<std::size_t>(params.anchors))
    anchors.resize(static_cast<std::size_t>(params.anchors));
  const std::size_t capacity = static_cast<std::size_t>(std::max(1, params.pose_candidates));
  std::vector<Hypothesis> kept;
  const float near2 = 4.0f * params.inlier_distance_m * params.inlier_distance_m;
  std::vector<std::uint32_t> support;
  for (std::uint32_t a : anchors) {
    const Match& ma = matches[a];
    support.assign(1, a);
    for (std::uint32_t b : partners[a]) {
      const Match& mb = matches[b];
      if ((ma.turn * (mb.model_point - ma.model_point) + ma.scene_point - mb.scene_point)
              .squaredNorm() < near2)
        support.push_back(b);
    }
    if (support.size() < 3) continue;
    const Eigen::Isometry3f pose = fittedPose(matches, support);
    const int inliers =
        static_cast<int>(agreeingMatches(pose, matches, params.inlier_distance_m).size());
    if (inliers >= params.min_inliers)
      keepHypothesis(kept, Hypothesis{pose, inliers}, capacity, model.box.centre);
  }
  for (Hypothesis& h : kept) h = refitOnAgreeing(h, matches, params);
  return kept;
}

// Step 2 for the model's flat faces and edges: each laid on each of the scene's
// (flat_faces.h), added to `hypotheses` where no such pose is there yet, at most
// max_flat_face_poses of them (a pose the features found is marked all the same). Their feature
// agreement is not counted here: it decides nothing for them and is only reported, so it is counted
// for the poses that verify (findObject).
void addFlatFacePoses(const ObjectModel& model, const SceneSurface& scene,
                      const ObjectMatchParams& params, std::vector<Hypothesis>& hypotheses) {
  const std::size_t most =
      hypotheses.size() + static_cast<std::size_t>(std::max(0, params.max_flat_face_poses));
  const auto add = [&](const Eigen::Isometry3f& pose) {
    const auto known = std::find_if(hypotheses.begin(), hypotheses.end(), [&](const Hypothesis& h) {
      return samePose(h.scene_from_model, pose, model.box.centre);
    });
    // A pose the features found too is laid by the faces all the same.
    if (known != hypotheses.end()) {
      known->source = PoseSource::kFlatFaces;
      return;
    }
    if (hypotheses.size() < most)
      hypotheses.push_back(Hypothesis{pose, 0, PoseSource::kFlatFaces, false});
  };
  const FlatFaces& found = scene.flatFaces();
  for (const FaceEdge& model_edge : model.flat_faces.edges)
    for (const FaceEdge& scene_edge : found.edges)
      for (const Eigen::Isometry3f& pose : edgeAlignedPoses(
               model_edge, scene_edge, params.edge_angle_tolerance_deg, params.face_size_slack_m))
        add(pose);
  // A face alone fixes less than an edge does (a face of another box of that size takes it),
  // so only models without an edge are laid by their faces.
  if (!model.flat_faces.edges.empty()) return;
  for (const FaceRectangle& model_face : model.flat_faces.faces)
    for (const FaceRectangle& scene_face : found.faces)
      for (const Eigen::Isometry3f& pose :
           faceAlignedPoses(model_face, scene_face, params.face_size_slack_m))
        add(pose);
}

// Step 2 for the scene's clusters: the model's box laid on each cluster's of about its size
// (surface_clusters.h), at most max_cluster_poses of them. As for flat faces, their feature
// agreement is counted only for the poses that verify.
void addClusterPoses(const ObjectModel& model, const SceneSurface& scene,
                     const ObjectMatchParams& params, std::vector<Hypothesis>& hypotheses) {
  const std::size_t most =
      hypotheses.size() + static_cast<std::size_t>(std::max(0, params.max_cluster_poses));
  const auto add = [&](const std::vector<Eigen::Isometry3f>& poses, PoseSource source) {
    for (const Eigen::Isometry3f& pose : poses) {
      if (hypotheses.size() >= most) return;
      hypotheses.push_back(Hypothesis{pose, 0, source, false});
    }
  };
  for (const SurfaceCluster& cluster : scene.clusters()) {
    if (model.standing_box && cluster.standing_box &&
        similarStandingSizes(*model.standing_box, *cluster.standing_box, params.cluster_size_slack))
      add(standingPoses(*model.standing_box, *cluster.standing_box), PoseSource::kStanding);
    if (similarBoxSizes(model.box, cluster.box, params.cluster_size_slack))
      add(boxAlignedPoses(model.box, cluster.box), PoseSource::kCluster);
  }
}

// Point-to-plane ICP, linearised about the current pose, with each model point facing the
// camera (at most `max_points` of them, evenly spread; 0 = all) paired by
// `partner(p, q, normal)` (false: no partner). Each pair also adds its point-to-point gap,
// weighted by `point_weight`: the plane term alone lets a face slide along itself, and a
// model point paired across the scene's edge only pulls it back in the plane of the face.
// With `upright` (an axis of the model), the pose only turns about that axis as posed, and
// moves freely.
template <class Partner>
Eigen::Isometry3f pointToPlaneIcp(Eigen::Isometry3f pose, const ObjectModel& model, int iterations,
                                  int max_points, float max_distance, double point_weight,
                                  const std::optional<Eigen::Vector3f>& upright,
                                  Partner&& partner) {
  const float max_d2 = max_distance * max_distance;
  const std::size_t stride = detail::thinningStep(model.surface.size(), max_points);
  Eigen::Vector3f q, normal;
  for (int iteration = 0; iteration < iterations; ++iteration) {
    detail::IcpNormalMatrix normal_matrix = detail::IcpNormalMatrix::Zero();
    detail::IcpStep rhs = detail::IcpStep::Zero();
    int pairs = 0;
    for (std::size_t i = 0; i < model.surface.size(); i += stride) {
      const Eigen::Vector3f p = pose * model.surface.points[i];
      const Eigen::Vector3f model_normal = pose.linear() * model.surface.normals[i];
      if (model_normal.dot(p) >= 0.0f) continue;  // facing away
      if (!partner(p, q, normal)) continue;
      if ((q - p).squaredNorm() > max_d2 || normal.dot(model_normal) < 0.5f) continue;
      const Eigen::Vector3d n = normal.cast<double>();
      const Eigen::Vector3d pd = p.cast<double>();
      Eigen::Matrix<double, 6, 1> row;
      row << pd.cross(n), n;
      normal_matrix += row * row.transpose();
      rhs += row * n.dot(q.cast<double>() - pd);
      if (point_weight > 0.0) {
        const Eigen::Vector3d gap = q.cast<double>() - pd;
        for (int k = 0; k < 3; ++k) {  // one row per axis of the gap
          const Eigen::Vector3d axis = Eigen::Vector3d::Unit(k);
          row << pd.cross(axis), axis;
          normal_matrix += point_weight * row * row.transpose();
          rhs += point_weight * row * gap[k];
        }
      }
      ++pairs;
    }
    if (pairs < 6) break;
    const detail::IcpStep step =
        upright ? detail::uprightStep(normal_matrix, rhs, (pose.linear() * *upright).cast<double>())
                : detail::IcpStep(normal_matrix.ldlt().solve(rhs));
    if (!step.allFinite()) break;
    const Eigen::Vector3d omega = step.head<3>();
    Eigen::Isometry3d delta = Eigen::Isometry3d::Identity();
    if (omega.norm() > 0.0)
      delta.linear() = Eigen::AngleAxisd(omega.norm(), omega.normalized()).toRotationMatrix();
    delta.translation() = step.tail<3>();
    pose = delta.cast<float>() * pose;
    // Converged: under 0.01 mm and 0.0006 deg a step.
    if (omega.norm() < 1e-5 && step.tail<3>().norm() < 1e-5) break;
  }
  return pose;
}

// How far from the posed model's points ICP may pair them: it pairs over icp_max_distance_m
// and may move the pose as far again, twice.
float icpReach(const ObjectMatchParams& params) { return 3.0f * params.icp_max_distance_m; }

Eigen::AlignedBox3f posedBounds(const ObjectModel& model, const Eigen::Isometry3f& pose) {
  Eigen::AlignedBox3f posed;  // empty
  for (const Eigen::Vector3f& p : model.surface.points) posed.extend(pose * p);
  return posed;
}

Eigen::AlignedBox3f grown(const Eigen::AlignedBox3f& box, float margin) {
  return {box.min() - Eigen::Vector3f::Constant(margin),
          box.max() + Eigen::Vector3f::Constant(margin)};
}

// What ICP from `pose` may pair the model's points with: their bounds grown by its reach.
Eigen::AlignedBox3f icpNeeds(const ObjectModel& model, const Eigen::Isometry3f& pose,
                             const ObjectMatchParams& params) {
  return grown(posedBounds(model, pose), icpReach(params));
}

// The bounds of the patch made for a pose needing `needed`: room to spare, so that it serves
// poses near that one too (ScenePatches).
Eigen::AlignedBox3f patchBounds(const Eigen::AlignedBox3f& needed,
                                const ObjectMatchParams& params) {
  return grown(needed, params.icp_max_distance_m);
}

// The scene points ICP may pair a model with while its pose stays near the one the patch was
// made for, with a nearest-point index over them: those within the bounds of the posed
// model's points, grown by what ICP can reach (ScenePatches). An index over the whole scene
// cost more to build than every query of a frame's models.
class ScenePatch {
 public:
  ScenePatch(const SceneSurface& scene, const Eigen::AlignedBox3f& bounds, float pair_distance)
      : scene_(scene), bounds_(bounds) {
    const std::vector<Eigen::Vector3f>& all = scene.surface().points;
    for (std::size_t i = 0; i < all.size(); ++i) {
      if (!bounds.contains(all[i])) continue;
      points_.push_back(all[i]);
      scene_index_.push_back(static_cast<std::uint32_t>(i));
    }
    index_ = std::make_unique<detail::CloudIndex>(points_, pair_distance);
  }
  ScenePatch(const ScenePatch&) = delete;
  ScenePatch& operator=(const ScenePatch&) = delete;

  /// Whether the patch holds every scene point within `bounds`.
  bool covers(const Eigen::AlignedBox3f& bounds) const { return bounds_.contains(bounds); }

  /// The nearest point of the patch at most the pairing distance from `p`, and its normal;
  /// false when there is none.
  bool nearestWithin(const Eigen::Vector3f& p, Eigen::Vector3f& q, Eigen::Vector3f& normal) const {
    float d2 = 0.0f;
    const int j = index_->nearestWithin(p, d2);
    if (j < 0) return false;
    const std::size_t i = scene_index_[static_cast<std::size_t>(j)];
    q = scene_.surface().points[i];
    normal = scene_.surface().normals[i];
    return true;
  }

 private:
  const SceneSurface& scene_;
  Eigen::AlignedBox3f bounds_;
  std::vector<Eigen::Vector3f> points_;  ///< the index refers to it: never reallocated after
  std::vector<std::uint32_t> scene_index_;
  std::unique_ptr<detail::CloudIndex> index_;
};

// The scene patches of one model's poses. The pose hypotheses of one object mostly lie at one
// place (the object turned), so a patch made with room to spare serves those near it.
class ScenePatches {
 public:
  ScenePatches(const ObjectModel& model, const SceneSurface& scene, const ObjectMatchParams& params)
      : model_(model), scene_(scene), params_(params) {}

  /// A patch for ICP from `pose` on, shared with earlier poses where one covers it; it lives as
  /// long as this.
  const ScenePatch& forPose(const Eigen::Isometry3f& pose) {
    const Eigen::AlignedBox3f needed = icpNeeds(model_, pose, params_);
    for (const auto& patch : patches_)
      if (patch->covers(needed)) return *patch;
    patches_.push_back(std::make_unique<ScenePatch>(scene_, patchBounds(needed, params_),
                                                    params_.icp_max_distance_m));
    return *patches_.back();
  }

 private:
  const ObjectModel& model_;
  const SceneSurface& scene_;
  const ObjectMatchParams& params_;
  std::vector<std::unique_ptr<ScenePatch>> patches_;
};

// Step 3: point-to-plane ICP, each model point paired with the nearest scene point (which
// holds a face from sliding past the scene's edges, as pairing along the line of sight does
// not), on at most `max_points` of the model; with `upright`, turning only about that model
// axis (pointToPlaneIcp).
Eigen::Isometry3f refinePose(const Eigen::Isometry3f& start, const ObjectModel& model,
                             const ScenePatch& patch, int iterations, int max_points,
                             const ObjectMatchParams& params,
                             const std::optional<Eigen::Vector3f>& upright = std::nullopt) {
  return pointToPlaneIcp(
      start, model, iterations, max_points, params.icp_max_distance_m,
      params.icp_point_to_point_weight, upright,
      [&](const Eigen::Vector3f& p, Eigen::Vector3f& q, Eigen::Vector3f& normal) {
        return patch.nearestWithin(p, q, normal);
      });
}

// The model axis a hypothesis's ICP keeps upright: a standing pose already has the model's
// support on the cluster's, and pairs on the few faces one view shows tilt it (a bowl by 3 deg,
// enough for its outline to show surface beyond it).
std::optional<Eigen::Vector3f> uprightAxis(const Hypothesis& hypothesis, const ObjectModel& model) {
  if (hypothesis.source != PoseSource::kStanding || !model.standing_box) return std::nullopt;
  return model.standing_box->axes.col(2);
}

struct Verification {
  int confirmed = 0;
  int contradicted = 0;
  int outline_seen = 0;       ///< outline probes with a reading
  int outline_continued = 0;  ///< ...at the object's depth
};

float confirmTolerance(float z, const ObjectMatchParams& params) {
  return std::max(params.confirm_distance_m,
                  params.confirm_steps * static_cast<float>(params.noise.depthStep(z)));
}

// The reading (m) where a camera-frame point projects; 0 outside the image or without one.
float readingAt(const Eigen::Vector3f& p, const SceneSurface& scene) {
  if (p.z() <= 0.0f) return 0.0f;
  const Eigen::Vector2d uv = scene.intrinsics().project(p.cast<double>());
  const long u = std::lround(uv.x());
  const long v = std::lround(uv.y());
  if (u < 0 || v < 0 || u >= scene.depth().cols || v >= scene.depth().rows) return 0.0f;
  return 1e-3f * static_cast<float>(
                     scene.depth().at<std::uint16_t>(static_cast<int>(v), static_cast<int>(u)));
}

// Step 4.
// The model's surface points that the depth confirms and contradicts at `pose` (into `out`).
void checkSurface(const Eigen::Isometry3f& pose, const ObjectModel& model,
                  const SceneSurface& scene, const ObjectMatchParams& params, Verification& out) {
  for (std::size_t i = 0; i < model.surface.size(); ++i) {
    const Eigen::Vector3f p = pose * model.surface.points[i];
    const Eigen::Vector3f n = pose.linear() * model.surface.normals[i];
    if (n.dot(p) >= 0.0f) continue;  // facing away
    const float measured = readingAt(p, scene);
    if (measured == 0.0f) continue;
    const float tolerance = confirmTolerance(p.z(), params);
    if (measured < p.z() - tolerance) continue;  // something in front of the object
    if (measured <= p.z() + tolerance) {
      ++out.confirmed;
    } else {
      ++out.contradicted;
    }
  }
}

// The outline probes that the depth sees, and those of them at the object's depth (into `out`).
void checkOutline(const Eigen::Isometry3f& pose, const ObjectModel& model,
                  const SceneSurface& scene, const ObjectMatchParams& params, Verification& out) {
  for (const Eigen::Vector3f& probe : model.outline_probes) {
    const Eigen::Vector3f p = pose * probe;
    const float measured = readingAt(p, scene);
    const float tolerance = confirmTolerance(p.z(), params);
    if (measured == 0.0f || measured < p.z() - tolerance) continue;  // unseen, or hidden
    ++out.outline_seen;
    if (std::abs(measured - p.z()) <= std::min(tolerance, params.outline_continuation_m))
      ++out.outline_continued;
  }
}

Verification verifyInDepth(const Eigen::Isometry3f& pose, const ObjectModel& model,
                           const SceneSurface& scene, const ObjectMatchParams& params) {
  Verification out;
  checkSurface(pose, model, scene, params, out);
  checkOutline(pose, model, scene, params, out);
  return out;
}

struct RankedHypothesis {
  Hypothesis hypothesis;
  int confirmed_within_reach = 0;  ///< model points the depth confirms within ICP's reach
};

// The poses from step 2 that go to ICP, most confirmed first: the `pose_hypotheses` the depth
// confirms most within ICP's reach (and up to `flat_face_hypotheses` more laid by flat faces), each
// confirming at least half the model points the final check needs (most wrong poses stop here,
// before their ICP). Feature agreement alone often ranks a wrong pose first: many of a box's
// features look alike.
std::vector<RankedHypothesis> worthRefining(std::vector<Hypothesis> hypotheses,
                                            const ObjectModel& model, const SceneSurface& scene,
                                            const ObjectMatchParams& params) {
  ObjectMatchParams within_reach = params;
  within_reach.confirm_distance_m = std::max(params.confirm_distance_m, params.icp_max_distance_m);
  const float needed = 0.5f * params.min_confirmed_share * static_cast<float>(model.surface.size());
  std::vector<RankedHypothesis> ranked;
  for (const Hypothesis& h : hypotheses) {
    Verification check;
    checkSurface(h.scene_from_model, model, scene, within_reach, check);
    if (static_cast<float>(check.confirmed) >= needed) ranked.push_back({h, check.confirmed});
  }
  std::stable_sort(ranked.begin(), ranked.end(), [](const auto& a, const auto& b) {
    return a.confirmed_within_reach > b.confirmed_within_reach;
  });
  // Besides the pose_hypotheses most confirmed, the flat_face_hypotheses most confirmed of the
  // poses from flat faces: a wrong pose from many agreeing features often outranks them.
  const auto keep = static_cast<std::size_t>(std::max(0, params.pose_hypotheses));
  int flat_left = std::max(0, params.flat_face_hypotheses);
  int cluster_left = std::max(0, params.cluster_hypotheses);
  std::size_t kept = 0;
  for (std::size_t i = 0; i < ranked.size(); ++i) {
    if (i >= keep) {
      const PoseSource source = ranked[i].hypothesis.source;
      int* left = source == PoseSource::kFlatFaces ? &flat_left
                  : source == PoseSource::kCluster || source == PoseSource::kStanding
                      ? &cluster_left
                      : nullptr;
      if (left == nullptr || *left == 0) continue;
      --*left;
    }
    ranked[kept++] = ranked[i];
  }
  ranked.resize(kept);
  return ranked;
}

// Whether a verified pose has the evidence its hypothesis asks for: a pose from the features
// that few of them agree with needs most of the model confirmed (strong_inliers); a pose laid
// by flat faces or on a cluster rests on geometry, not on feature matches.
bool enoughEvidence(const ObjectDetection& detection, const Hypothesis& hypothesis,
                    const ObjectModel& model, const ObjectMatchParams& params) {
  const auto confirmed = [&](float share) {
    return static_cast<float>(detection.confirmed_points) >=
           share * static_cast<float>(model.surface.size());
  };
  if (hypothesis.source == PoseSource::kFlatFaces) return true;
  if (hypothesis.source == PoseSource::kStanding && confirmed(params.standing_pose_confirmed_share))
    return true;
  return hypothesis.inliers >= params.strong_inliers || confirmed(params.weak_pose_confirmed_share);
}

OrientedBox boxInCamera(const OrientedBox& box, const Eigen::Isometry3f& pose) {
  OrientedBox out = box;
  out.centre = pose * box.centre;
  out.axes = pose.linear() * box.axes;
  return out;
}

}  // namespace

SceneSurface::SceneSurface(const cv::Mat& depth_mm, const CameraIntrinsics& intrinsics,
                           const ObjectModelParams& params, const cv::Mat& mask,
                           const PlaneDetection* planes)
    : depth_mm_(depth_mm),
      intrinsics_(intrinsics),
      surface_(surfaceCloudFromDepth(depth_mm, intrinsics, mask, params.surface)),
      feature_params_(params.features),
      flat_face_params_(params.flat_faces),
      cluster_params_(params.clusters) {
  if (planes) std::call_once(flat_faces_found_, [&] { findFlatFaces(*planes); });
}

const std::vector<ShapeFeature>& SceneSurface::features() const {
  describe();
  return features_;
}

const std::vector<float>& SceneSurface::descriptorColumns() const {
  describe();
  return descriptor_columns_;
}

void SceneSurface::describe() const {
  std::call_once(described_, [this] {
    features_ = detectShapeFeatures(surface_, feature_params_);
    descriptor_columns_.resize(features_.size() * kShapeDescriptorSize);
    for (std::size_t i = 0; i < features_.size(); ++i)
      for (std::size_t d = 0; d < kShapeDescriptorSize; ++d)
        descriptor_columns_[d * features_.size() + i] = features_[i].descriptor[d];
  });
}

const FlatFaces& SceneSurface::flatFaces() const {
  std::call_once(flat_faces_found_,
                 [this] { findFlatFaces(HoughPlaneDetector().detect(depth_mm_, intrinsics_)); });
  return flat_faces_;
}

const std::vector<SurfaceCluster>& SceneSurface::clusters() const {
  std::call_once(clustered_,
                 [this] { clusters_ = surfaceClusters(surface_, flatFaces(), cluster_params_); });
  return clusters_;
}

void SceneSurface::findFlatFaces(const PlaneDetection& planes) const {
  flat_faces_ = flatFacesOfPlanes(planes, depth_mm_, intrinsics_, flat_face_params_);
}

SceneSurface::~SceneSurface() = default;

std::optional<ObjectDetection> findObject(const ObjectModel& model, const SceneSurface& scene,
                                          const ObjectMatchParams& params) {
  const std::vector<Match> matches = candidateMatches(model, scene, params);
  // Every hypothesis is refined on a share of the model and checked; only the winner is
  // refined on all of it.
  std::optional<ObjectDetection> best;
  ScenePatches patches(model, scene, params);
  const ScenePatch* best_patch = nullptr;
  std::optional<Eigen::Vector3f> best_upright;
  std::vector<Hypothesis> hypotheses = anchoredPoses(matches, model, params);
  if (params.poses_from_flat_faces) addFlatFacePoses(model, scene, params, hypotheses);
  if (params.poses_from_clusters) addClusterPoses(model, scene, params, hypotheses);
  for (const auto& [hypothesis, confirmed_within_reach] :
       worthRefining(std::move(hypotheses), model, scene, params)) {
    // Hypotheses come most confirmed first, counted within ICP's reach: refined and checked at
    // the final tolerance, a pose rarely confirms more than that, so one that a verified pose
    // already matches cannot win.
    if (best && best->confirmed_points >= confirmed_within_reach) break;
    const ScenePatch& patch = patches.forPose(hypothesis.scene_from_model);
    const std::optional<Eigen::Vector3f> upright = uprightAxis(hypothesis, model);
    const Eigen::Isometry3f pose =
        refinePose(hypothesis.scene_from_model, model, patch, params.icp_iterations,
                   params.icp_max_points, params, upright);
    auto detection = verifyObjectPose(model, scene, pose, params);
    if (!detection || !enoughEvidence(*detection, hypothesis, model, params)) continue;
    detection->feature_inliers =
        hypothesis.inliers_counted
            ? hypothesis.inliers
            : static_cast<int>(
                  agreeingMatches(hypothesis.scene_from_model, matches, params.inlier_distance_m)
                      .size());
    if (!best || detection->confirmed_points > best->confirmed_points) {
      best = detection;
      best_patch = &patch;
      best_upright = upright;
    }
  }
  if (!best) return best;
  const Eigen::Isometry3f final_pose =
      refinePose(best->camera_from_model, model, *best_patch, params.icp_final_iterations, 0,
                 params, best_upright);
  auto final_detection = verifyObjectPose(model, scene, final_pose, params);
  if (!final_detection) return best;
  final_detection->feature_inliers = best->feature_inliers;
  return final_detection;
}

std::optional<ObjectDetection> followObject(const ObjectModel& model, const SceneSurface& scene,
                                            const Eigen::Isometry3f& prior,
                                            const ObjectMatchParams& params) {
  const ScenePatch patch(scene, patchBounds(icpNeeds(model, prior, params), params),
                         params.icp_max_distance_m);
  Eigen::Isometry3f pose =
      refinePose(prior, model, patch, params.icp_iterations, params.icp_max_points, params);
  pose = refinePose(pose, model, patch, params.icp_final_iterations, 0, params);
  return verifyObjectPose(model, scene, pose, params);
}

cv::Rect followObjectRegion(const ObjectModel& model, const Eigen::Isometry3f& prior,
                            const CameraIntrinsics& intrinsics, const ObjectMatchParams& params) {
  // The bounds of the patch followObject makes, so the surface in this region holds every
  // scene point it may pair with.
  const Eigen::AlignedBox3f reached = patchBounds(icpNeeds(model, prior, params), params);
  if (reached.isEmpty()) return {};
  // A region reaching behind or right up to the camera projects without bound: all of it.
  constexpr float kNearestZ = 0.05f;
  if (reached.min().z() < kNearestZ) return cv::Rect(0, 0, intrinsics.width, intrinsics.height);
  std::array<Eigen::Vector3d, 8> corners;
  for (int i = 0; i < 8; ++i)
    corners[static_cast<std::size_t>(i)] =
        reached.corner(static_cast<Eigen::AlignedBox3f::CornerType>(i)).cast<double>();
  return projectedBounds(corners, intrinsics);
}

PoseCheck checkObjectPose(const ObjectModel& model, const SceneSurface& scene,
                          const Eigen::Isometry3f& pose, const ObjectMatchParams& params) {
  const Verification check = verifyInDepth(pose, model, scene, params);
  PoseCheck out;
  out.confirmed = check.confirmed;
  out.contradicted = check.contradicted;
  out.outline_seen = check.outline_seen;
  out.outline_continued = check.outline_continued;
  const int seen = check.confirmed + check.contradicted;
  if (seen > 0) out.score = static_cast<float>(check.confirmed) / static_cast<float>(seen);
  const auto figures = [](const char* what, double value, const char* relation, double bound) {
    char text[96];
    std::snprintf(text, sizeof text, "%s %.4f %s %.4g", what, value, relation, bound);
    return std::string(text);
  };
  const bool has_outline = !model.outline_probes.empty();
  const auto probes = static_cast<float>(model.outline_probes.size());
  if (seen == 0) {
    out.failed = "no model point facing the camera has a reading";
  } else if (out.score < params.min_score) {
    out.failed = figures("score", out.score, "<", params.min_score);
  } else if (check.confirmed <
             params.min_confirmed_share * static_cast<float>(model.surface.size())) {
    out.failed = figures("confirmed share", check.confirmed / double(model.surface.size()), "<",
                         params.min_confirmed_share);
  } else if (has_outline && check.outline_seen < params.min_seen_outline * probes) {
    out.failed =
        figures("outline seen", check.outline_seen / double(probes), "<", params.min_seen_outline);
  } else if (has_outline && check.outline_continued > params.max_continued_outline *
                                                          static_cast<float>(check.outline_seen)) {
    out.failed = figures("outline continued", check.outline_continued / double(check.outline_seen),
                         ">", params.max_continued_outline);
  }
  return out;
}

std::optional<ObjectDetection> verifyObjectPose(const ObjectModel& model, const SceneSurface& scene,
                                                const Eigen::Isometry3f& pose,
                                                const ObjectMatchParams& params) {
  const PoseCheck check = checkObjectPose(model, scene, pose, params);
  if (!check.failed.empty()) return std::nullopt;
  ObjectDetection out;
  out.name = model.name;
  out.camera_from_model = pose;
  out.score = check.score;
  out.confirmed_points = check.confirmed;
  out.box = boxInCamera(model.box, pose);
  return out;
}

}  // namespace shapesense
