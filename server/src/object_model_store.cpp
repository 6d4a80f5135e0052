#include "shapesense/server/object_model_store.h"

#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <system_error>

#include <spdlog/spdlog.h>

#include "shapesense/core/recognition/object_model_file.h"
#include "shapesense/server/recording_root.h"

namespace shapesense {
namespace fs = std::filesystem;

namespace {

std::int64_t modifiedAtNs(const fs::path& file) {
  std::error_code error;
  const auto written = fs::last_write_time(file, error);
  if (error) return 0;
  const auto system = std::chrono::file_clock::to_sys(written);
  return std::chrono::duration_cast<std::chrono::nanoseconds>(system.time_since_epoch()).count();
}

}  // namespace

fs::path defaultObjectModelsDir() { return defaultRecordRoot().parent_path() / "object-models"; }

ObjectModelStore::ObjectModelStore(fs::path dir, std::size_t max_models, ObjectModelParams params)
    : dir_(std::move(dir)), max_models_(max_models), params_(std::move(params)) {
  load();
}

void ObjectModelStore::load() {
  std::error_code error;
  fs::create_directories(dir_, error);
  if (error) {
    spdlog::warn("cannot create the object models folder {}: {}; TeachObject will fail",
                 dir_.string(), error.message());
  }
  fs::directory_iterator entries(dir_, error);
  if (error) {
    spdlog::warn("cannot read the object models folder {}: {}; no objects are taught",
                 dir_.string(), error.message());
    return;
  }
  for (const auto& entry : entries) {
    const fs::path& file = entry.path();
    // Skips saveObjectModel's temporary files and anything else that is not a model.
    if (file.extension() != ".json" || file.filename().string().front() == '.') continue;
    try {
      ObjectModel model = loadObjectModel(file, params_);
      if (model.name != file.stem().string()) {
        throw std::runtime_error(file.string() + " holds the model '" + model.name +
                                 "'; rename the file to " + model.name + ".json");
      }
      if (models_.size() >= max_models_) {
        throw std::runtime_error(file.string() + ": the folder holds more than " +
                                 std::to_string(max_models_) +
                                 " models (shapesensed --object-models-max)");
      }
      const std::string name = model.name;
      models_[name] = {std::make_shared<const ObjectModel>(std::move(model)), modifiedAtNs(file)};
    } catch (const std::exception& e) {
      spdlog::warn("object model skipped: {}", e.what());
      skipped_.push_back(e.what());
    }
  }
  spdlog::info("{} object models loaded from {}", models_.size(), dir_.string());
}

std::vector<StoredObjectModel> ObjectModelStore::list() const {
  std::lock_guard lock(mutex_);
  std::vector<StoredObjectModel> models;
  models.reserve(models_.size());
  for (const auto& [name, stored] : models_) models.push_back(stored);
  return models;
}

std::optional<StoredObjectModel> ObjectModelStore::get(const std::string& name) const {
  std::lock_guard lock(mutex_);
  const auto found = models_.find(name);
  if (found == models_.end()) return std::nullopt;
  return found->second;
}

bool ObjectModelStore::contains(const std::string& name) const {
  std::lock_guard lock(mutex_);
  return models_.contains(name);
}

grpc::Status ObjectModelStore::admits(const std::string& name, bool replace) const {
  std::lock_guard lock(mutex_);
  return admitsLocked(name, replace);
}

grpc::Status ObjectModelStore::admitsLocked(const std::string& name, bool replace) const {
  if (models_.contains(name)) {
    if (replace) return grpc::Status::OK;
    return {grpc::StatusCode::ALREADY_EXISTS,
            "an object named '" + name + "' is taught already: choose another name or replace it"};
  }
  if (models_.size() >= max_models_) {
    return {grpc::StatusCode::RESOURCE_EXHAUSTED,
            "the daemon holds " + std::to_string(max_models_) +
                " object models already (shapesensed --object-models-max): replace one"};
  }
  return grpc::Status::OK;
}

grpc::Status ObjectModelStore::add(ObjectModel model, bool replace, StoredObjectModel& stored,
                                   bool& replaced) {
  // Held while writing: two teachers of one name must not interleave file and memory.
  std::lock_guard lock(mutex_);
  if (auto status = admitsLocked(model.name, replace); !status.ok()) return status;
  const fs::path file = dir_ / (model.name + ".json");
  if (::access(dir_.c_str(), W_OK) != 0 && (errno == EACCES || errno == EROFS || errno == EPERM)) {
    return {grpc::StatusCode::PERMISSION_DENIED,
            "the daemon may not write to its object models folder " + dir_.string() + " (" +
                std::generic_category().message(errno) + ")"};
  }
  try {
    saveObjectModel(model, params_, file);
  } catch (const std::exception& e) {
    spdlog::warn("cannot save object model {}: {}", file.string(), e.what());
    std::error_code ignored;
    fs::remove(file.string() + ".tmp", ignored);
    return {grpc::StatusCode::FAILED_PRECONDITION,
            "cannot save the model in the daemon's object models folder " + dir_.string() + ": " +
                e.what()};
  }
  replaced = models_.contains(model.name);
  const std::string name = model.name;
  stored = {std::make_shared<const ObjectModel>(std::move(model)), modifiedAtNs(file)};
  models_[name] = stored;
  return grpc::Status::OK;
}

}  // namespace shapesense
