#include "shapesense/core/bowls/bowl_model.h"

#include <cstdint>
#include <fstream>
#include <limits>
#include <stdexcept>

#include <nlohmann/json.hpp>

namespace shapesense {

using nlohmann::json;

namespace {

// A JSON integer that fits T. nlohmann's get<int>() converts a float such as 1e300 with
// undefined behaviour; a model file holding one is malformed instead.
template <typename T>
T integerOf(const json& value) {
  if (!value.is_number_integer()) {
    throw std::runtime_error(std::string("expected an integer, got ") + value.type_name());
  }
  constexpr auto kMin = static_cast<std::int64_t>(std::numeric_limits<T>::min());
  constexpr auto kMax = static_cast<std::int64_t>(std::numeric_limits<T>::max());
  const bool fits = value.is_number_unsigned()
                        ? value.get<std::uint64_t>() <= static_cast<std::uint64_t>(kMax)
                        : value.get<std::int64_t>() >= kMin && value.get<std::int64_t>() <= kMax;
  if (!fits) throw std::runtime_error("integer " + value.dump() + " out of range");
  return static_cast<T>(value.get<std::int64_t>());
}

}  // namespace

void saveBowlModel(const BowlViewModel& m, const std::filesystem::path& file) {
  json j;
  j["format"] = "shapesense-bowl-model";
  j["version"] = kBowlModelVersion;
  j["view"] = m.view;
  j["window"] = {{"width", m.classifier.win_w}, {"height", m.classifier.win_h}};
  j["object_margin"] = m.object_margin;
  j["object_width_m"] = {m.min_object_width_m, m.max_object_width_m};
  const auto& p = m.preprocess;
  j["preprocess"] = {{"near_m", p.near_m},
                     {"far_m", p.far_m},
                     {"low", p.low},
                     {"high", p.high},
                     {"fill_passes", p.fill_passes},
                     {"unfilled_value", p.unfilled_value}};
  j["score_unit"] = kWaldBoostScoreUnit;
  j["lbp"] = {{"bit_order", "clockwise-from-top-left"}, {"compare", "neighbour >= centre"}};
  j["training"] = json::parse(m.training_json.empty() ? "{}" : m.training_json);
  if (const auto& op = m.operating_point) {
    j["operating_point"] = {{"score_threshold", op->score_threshold},
                            {"unverified_score_threshold", op->unverified_score_threshold},
                            {"chosen_on", op->chosen_on}};
  }
  json stages = json::array();
  for (const auto& s : m.classifier.stages) {
    json js = {{"x", s.feature.x}, {"y", s.feature.y}, {"cw", s.feature.cw}, {"ch", s.feature.ch}};
    js["threshold"] = s.threshold == INT32_MIN ? json(nullptr) : json(s.threshold);
    js["lut"] = s.lut;
    stages.push_back(std::move(js));
  }
  j["stages"] = std::move(stages);
  const auto tmp = std::filesystem::path(file.string() + ".tmp");
  {
    std::ofstream out(tmp);
    if (!out) throw std::runtime_error("cannot write " + tmp.string());
    // One stage per line keeps diffs of retrained models readable and the file compact.
    out << "{\n";
    bool first = true;
    for (auto it = j.begin(); it != j.end(); ++it) {
      if (it.key() == "stages") continue;
      out << (first ? "" : ",\n") << "  " << json(it.key()).dump() << ": " << it.value().dump();
      first = false;
    }
    out << ",\n  \"stages\": [\n";
    for (std::size_t i = 0; i < j["stages"].size(); ++i)
      out << "    " << j["stages"][i].dump() << (i + 1 < j["stages"].size() ? ",\n" : "\n");
    out << "  ]\n}\n";
    if (!out) throw std::runtime_error("cannot write " + tmp.string());
  }
  std::filesystem::rename(tmp, file);
}

BowlViewModel loadBowlModel(const std::filesystem::path& file) {
  std::ifstream in(file);
  if (!in) throw std::runtime_error("cannot open bowl model " + file.string());
  try {
    const json j = json::parse(in);
    if (j.at("format").get<std::string>() != "shapesense-bowl-model")
      throw std::runtime_error("not a shapesense-bowl-model");
    if (integerOf<int>(j.at("version")) != kBowlModelVersion)
      throw std::runtime_error("unsupported version " + j.at("version").dump());
    BowlViewModel m;
    m.view = j.at("view").get<std::string>();
    m.classifier.win_w = integerOf<int>(j.at("window").at("width"));
    m.classifier.win_h = integerOf<int>(j.at("window").at("height"));
    m.object_margin = j.at("object_margin").get<double>();
    m.min_object_width_m = j.at("object_width_m").at(0).get<double>();
    m.max_object_width_m = j.at("object_width_m").at(1).get<double>();
    const auto& p = j.at("preprocess");
    m.preprocess.near_m = p.at("near_m").get<double>();
    m.preprocess.far_m = p.at("far_m").get<double>();
    m.preprocess.low = integerOf<int>(p.at("low"));
    m.preprocess.high = integerOf<int>(p.at("high"));
    m.preprocess.fill_passes = integerOf<int>(p.at("fill_passes"));
    m.preprocess.unfilled_value = integerOf<int>(p.at("unfilled_value"));
    if (j.at("score_unit").get<double>() != kWaldBoostScoreUnit)
      throw std::runtime_error("unsupported score_unit");
    m.training_json = j.contains("training") ? j["training"].dump() : "{}";
    if (j.contains("operating_point")) {
      const auto& op = j.at("operating_point");
      m.operating_point = BowlOperatingPoint{
          .score_threshold = op.at("score_threshold").get<double>(),
          .unverified_score_threshold = op.at("unverified_score_threshold").get<double>(),
          .chosen_on = op.at("chosen_on").get<std::string>()};
    }
    for (const auto& js : j.at("stages")) {
      WaldBoostStage s;
      s.feature = {integerOf<int>(js.at("x")), integerOf<int>(js.at("y")),
                   integerOf<int>(js.at("cw")), integerOf<int>(js.at("ch"))};
      const auto& f = s.feature;
      // In 64 bits: x + 3 * cw of two ints does not overflow there.
      if (f.x < 0 || f.y < 0 || f.cw < 1 || f.ch < 1 ||
          f.x + 3 * std::int64_t{f.cw} > m.classifier.win_w ||
          f.y + 3 * std::int64_t{f.ch} > m.classifier.win_h)
        throw std::runtime_error("stage feature outside the window");
      s.threshold =
          js.at("threshold").is_null() ? INT32_MIN : integerOf<std::int32_t>(js.at("threshold"));
      const auto& lut = js.at("lut");
      if (lut.size() != 256) throw std::runtime_error("lut must have 256 entries");
      for (int k = 0; k < 256; ++k) s.lut[k] = integerOf<std::int16_t>(lut.at(k));
      m.classifier.stages.push_back(s);
    }
    return m;
  } catch (const std::exception& e) {
    throw std::runtime_error("bad bowl model " + file.string() + ": " + e.what());
  }
}

}  // namespace shapesense
