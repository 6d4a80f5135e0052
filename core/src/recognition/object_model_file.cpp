#include "shapesense/core/recognition/object_model_file.h"

#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <nlohmann/json.hpp>

namespace shapesense {
namespace {

using nlohmann::json;

constexpr std::size_t kMaxSurfacePoints = 200'000;
constexpr std::size_t kMaxFeatures = 50'000;
constexpr std::size_t kMaxOutlineProbes = 50'000;
constexpr double kMaxCoordinateM = 1000.0;

float finiteNumber(const json& value, double limit) {
  if (!value.is_number())
    throw std::runtime_error("expected a number, got " + std::string(value.type_name()));
  const double v = value.get<double>();
  if (!std::isfinite(v) || std::abs(v) > limit)
    throw std::runtime_error("number " + value.dump() + " out of range");
  return static_cast<float>(v);
}

template <int N>
Eigen::Matrix<float, N, 1> numbers(const json& array, double limit) {
  if (!array.is_array() || array.size() != static_cast<std::size_t>(N))
    throw std::runtime_error("expected an array of " + std::to_string(N) + " numbers");
  Eigen::Matrix<float, N, 1> out;
  for (int i = 0; i < N; ++i) out[i] = finiteNumber(array[static_cast<std::size_t>(i)], limit);
  return out;
}

Eigen::Matrix3f rotation(const json& array) {
  const Eigen::Matrix<float, 9, 1> v = numbers<9>(array, 1.01);
  Eigen::Matrix3f m = Eigen::Map<const Eigen::Matrix3f>(v.data());
  if (!(m.transpose() * m).isApprox(Eigen::Matrix3f::Identity(), 1e-3f))
    throw std::runtime_error("a frame is not a rotation");
  return m;
}

const json& arrayAt(const json& j, const char* key, std::size_t max_size) {
  const json& a = j.at(key);
  if (!a.is_array()) throw std::runtime_error(std::string(key) + " must be an array");
  if (a.size() > max_size)
    throw std::runtime_error(std::string(key) + " holds " + std::to_string(a.size()) +
                             " entries, more than " + std::to_string(max_size));
  return a;
}

json vec(const Eigen::Ref<const Eigen::VectorXf>& v) {
  json out = json::array();
  for (Eigen::Index i = 0; i < v.size(); ++i) out.push_back(v[i]);
  return out;
}

json mat(const Eigen::Matrix3f& m) {
  return vec(Eigen::Map<const Eigen::Matrix<float, 9, 1>>(m.data()));
}

void checkDescriptorParams(const json& d, const ObjectModelParams& params) {
  const auto same = [](const json& value, double expected) {
    return value.is_number() && std::abs(value.get<double>() - expected) <= 1e-6;
  };
  if (!same(d.at("support_radius_m"), params.features.support_radius_m) ||
      !same(d.at("height_image_size"), params.features.height_image_size) ||
      !same(d.at("cells"), kShapeDescriptorCells) || !same(d.at("voxel_m"), params.surface.voxel_m))
    throw std::runtime_error("described with other descriptor parameters (" + d.dump() +
                             ") than this build uses: teach it again");
}

ObjectModel parseObjectModelJson(const json& j, const ObjectModelParams& params) {
  if (!j.is_object() || j.value("format", "") != "shapesense-object-model")
    throw std::runtime_error("not a shapesense-object-model");
  if (j.at("version").is_number_integer() && j.at("version").get<int>() >= 1 &&
      j.at("version").get<int>() < kObjectModelVersion) {
    throw std::runtime_error("version " + j.at("version").dump() +
                             ": its features were described in other local frames than this "
                             "build's: teach it again");
  }
  if (j.at("version") != kObjectModelVersion)
    throw std::runtime_error("unsupported version " + j.at("version").dump());
  checkDescriptorParams(j.at("descriptor"), params);
  ObjectModel model;
  model.name = j.at("name").get<std::string>();
  if (!isValidObjectModelName(model.name)) throw std::runtime_error("invalid object name");
  for (const json& row : arrayAt(j, "surface", kMaxSurfacePoints)) {
    const Eigen::Matrix<float, 6, 1> v = numbers<6>(row, kMaxCoordinateM);
    const Eigen::Vector3f normal = v.tail<3>();
    if (std::abs(normal.norm() - 1.0f) > 1e-3f) throw std::runtime_error("a normal is not unit");
    model.surface.points.push_back(v.head<3>());
    model.surface.normals.push_back(normal);
  }
  for (const json& f : arrayAt(j, "features", kMaxFeatures)) {
    ShapeFeature feature;
    feature.position = numbers<3>(f.at("p"), kMaxCoordinateM);
    feature.frame = rotation(f.at("frame"));
    feature.response = finiteNumber(f.at("response"), 10.0);
    const auto descriptor = numbers<kShapeDescriptorSize>(f.at("descriptor"), 1e3);
    std::copy(descriptor.data(), descriptor.data() + kShapeDescriptorSize,
              feature.descriptor.begin());
    model.features.push_back(feature);
  }
  const json& box = j.at("box");
  model.box.centre = numbers<3>(box.at("centre"), kMaxCoordinateM);
  model.box.axes = rotation(box.at("axes"));
  model.box.size = numbers<3>(box.at("size"), kMaxCoordinateM);
  for (const json& p : arrayAt(j, "outline_probes", kMaxOutlineProbes))
    model.outline_probes.push_back(numbers<3>(p, kMaxCoordinateM));
  model.flat_faces = flatFacesOfSurface(model.surface, params.flat_faces);
  // Models saved without it stand on nothing.
  if (j.contains("support")) {
    const Eigen::Vector4f support = numbers<4>(j.at("support"), kMaxCoordinateM);
    if (std::abs(support.head<3>().norm() - 1.0f) > 1e-3f)
      throw std::runtime_error("the support's normal is not unit");
    standOn(model, support, params.clusters);
  }
  return model;
}

}  // namespace

bool isValidObjectModelName(std::string_view name) {
  if (name.empty() || name.size() > 64 || name.front() == '.') return false;
  for (char c : name) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                    c == '-' || c == '_' || c == '.';
    if (!ok) return false;
  }
  return true;
}

std::string objectModelToJson(const ObjectModel& model, const ObjectModelParams& params) {
  json j;
  j["format"] = "shapesense-object-model";
  j["version"] = kObjectModelVersion;
  j["name"] = model.name;
  j["descriptor"] = {{"support_radius_m", params.features.support_radius_m},
                     {"height_image_size", params.features.height_image_size},
                     {"cells", kShapeDescriptorCells},
                     {"voxel_m", params.surface.voxel_m}};
  json surface = json::array();
  for (std::size_t i = 0; i < model.surface.size(); ++i) {
    Eigen::Matrix<float, 6, 1> row;
    row << model.surface.points[i], model.surface.normals[i];
    surface.push_back(vec(row));
  }
  j["surface"] = std::move(surface);
  json features = json::array();
  for (const ShapeFeature& f : model.features) {
    features.push_back({{"p", vec(f.position)},
                        {"frame", mat(f.frame)},
                        {"response", f.response},
                        {"descriptor", vec(Eigen::Map<const Eigen::VectorXf>(
                                           f.descriptor.data(), kShapeDescriptorSize))}});
  }
  j["features"] = std::move(features);
  j["box"] = {{"centre", vec(model.box.centre)},
              {"axes", mat(model.box.axes)},
              {"size", vec(model.box.size)}};
  json probes = json::array();
  for (const auto& p : model.outline_probes) probes.push_back(vec(p));
  j["outline_probes"] = std::move(probes);
  if (model.support) j["support"] = vec(*model.support);
  return j.dump();
}

ObjectModel parseObjectModel(std::string_view text, const ObjectModelParams& params) {
  try {
    return parseObjectModelJson(json::parse(text.begin(), text.end()), params);
  } catch (const json::exception& e) {
    throw std::runtime_error(e.what());
  }
}

void saveObjectModel(const ObjectModel& model, const ObjectModelParams& params,
                     const std::filesystem::path& file) {
  const std::filesystem::path tmp = file.string() + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out << objectModelToJson(model, params) << '\n';
    if (!out) throw std::runtime_error("cannot write " + tmp.string());
  }
  std::filesystem::rename(tmp, file);
}

ObjectModel loadObjectModel(const std::filesystem::path& file, const ObjectModelParams& params) {
  try {
    if (!std::filesystem::is_regular_file(file)) throw std::runtime_error("not a regular file");
    if (std::filesystem::file_size(file) > kMaxObjectModelFileBytes)
      throw std::runtime_error("larger than " + std::to_string(kMaxObjectModelFileBytes) +
                               " bytes");
    std::ifstream in(file, std::ios::binary);
    if (!in) throw std::runtime_error("cannot open it");
    std::ostringstream text;
    text << in.rdbuf();
    return parseObjectModel(text.str(), params);
  } catch (const std::exception& e) {
    throw std::runtime_error("bad object model " + file.string() + ": " + e.what());
  }
}

}  // namespace shapesense
