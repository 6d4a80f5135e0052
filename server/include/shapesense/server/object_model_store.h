#pragma once
// The taught objects of the daemon: one `<name>.json` per model in one folder (shapesensed
// --object-models), loaded at start and kept in memory, so that FindObjects never reads a file.
// TeachObject adds to it; nothing else writes to the folder. Thread-safe.

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <grpcpp/support/status.h>

#include "shapesense/core/recognition/object_model.h"

namespace shapesense {

/// The object models folder when --object-models is not given: `object-models` beside the
/// default recordings root ($STATE_DIRECTORY/object-models under systemd, else
/// $XDG_STATE_HOME or ~/.local/state, /shapesense/object-models).
std::filesystem::path defaultObjectModelsDir();

struct StoredObjectModel {
  std::shared_ptr<const ObjectModel> model;
  std::int64_t taught_at_ns = 0;  ///< the file's modification time, ns since the epoch
};

class ObjectModelStore {
 public:
  /// Default for max_models: enough for a workbench's objects while FindObjects over all of
  /// them stays within a frame period or two.
  static constexpr std::size_t kDefaultMaxModels = 32;

  /// Creates `dir` when missing (a failure is logged; then teaching answers why) and loads
  /// every `*.json` in it. A file that does not load (malformed, another descriptor, a name
  /// that does not match its file) is logged with its reason and skipped.
  explicit ObjectModelStore(std::filesystem::path dir, std::size_t max_models = kDefaultMaxModels,
                            ObjectModelParams params = {});

  const std::filesystem::path& dir() const { return dir_; }
  std::size_t maxModels() const { return max_models_; }
  /// What models were taught and are looked for with: scenes must be described alike.
  const ObjectModelParams& params() const { return params_; }
  /// The files skipped at load, each "FILE: reason".
  const std::vector<std::string>& skipped() const { return skipped_; }

  /// Every model, by name.
  std::vector<StoredObjectModel> list() const;
  std::optional<StoredObjectModel> get(const std::string& name) const;
  bool contains(const std::string& name) const;

  /// Whether a model named `name` could be added now: OK, or ALREADY_EXISTS (unless
  /// `replace`), RESOURCE_EXHAUSTED (the folder is full). A cheap check before the work of
  /// teaching; add() checks again.
  grpc::Status admits(const std::string& name, bool replace) const;
  /// Saves `model` as `<name>.json` (atomically) and keeps it. As admits(), and
  /// PERMISSION_DENIED / FAILED_PRECONDITION when the file cannot be written. `replaced` says
  /// whether a model of that name was there.
  grpc::Status add(ObjectModel model, bool replace, StoredObjectModel& stored, bool& replaced);

 private:
  grpc::Status admitsLocked(const std::string& name, bool replace) const;
  void load();

  std::filesystem::path dir_;
  std::size_t max_models_;
  ObjectModelParams params_;
  std::vector<std::string> skipped_;
  mutable std::mutex mutex_;
  std::map<std::string, StoredObjectModel> models_;
};

}  // namespace shapesense
