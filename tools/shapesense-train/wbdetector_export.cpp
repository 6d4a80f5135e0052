#include "wbdetector_export.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "dataset.h"
#include "shapesense/core/bowls/depth_preprocess.h"

namespace shapesense::train {

namespace fs = std::filesystem;

void writeWbDetectorMeta(const fs::path& file, const WbDetectorMeta& meta) {
  cv::FileStorage f(file.string(), cv::FileStorage::WRITE);
  if (!f.isOpened()) throw std::runtime_error("cannot write " + file.string());
  f << "aspect" << meta.aspect << "margin" << meta.margin << "window" << meta.window;
}

WbDetectorMeta readWbDetectorMeta(const fs::path& file) {
  cv::FileStorage f(file.string(), cv::FileStorage::READ);
  if (!f.isOpened()) throw std::runtime_error("cannot read " + file.string());
  WbDetectorMeta m;
  f["aspect"] >> m.aspect;
  f["margin"] >> m.margin;
  f["window"] >> m.window;
  if (!(m.aspect > 0.1 && m.aspect < 10) || !(m.margin >= 0 && m.margin < 0.5) || m.window < 8)
    throw std::runtime_error("malformed WBDetector meta " + file.string());
  return m;
}

cv::Mat stretchForView(const cv::Mat& img8, const WbDetectorMeta& meta) {
  cv::Mat out;
  const int rows = static_cast<int>(std::lround(img8.rows / meta.aspect));
  // Linear: the depth image is smooth, and nearest would duplicate rows in a pattern the
  // classifier could key on.
  cv::resize(img8, out, cv::Size(img8.cols, rows), 0, 0, cv::INTER_LINEAR);
  return out;
}

cv::Rect windowToObjectBox(const cv::Rect& window, const WbDetectorMeta& meta) {
  const double m = meta.margin;
  const double x = window.x + m * window.width;
  const double y = (window.y + m * window.height) * meta.aspect;
  const double w = window.width * (1 - 2 * m);
  const double h = window.height * (1 - 2 * m) * meta.aspect;
  return {static_cast<int>(std::lround(x)), static_cast<int>(std::lround(y)),
          static_cast<int>(std::lround(w)), static_cast<int>(std::lround(h))};
}

namespace {

// The window around `box` in the stretched image: square, centred on the box, side = the box
// width / (1 - 2 margin) (the stretched box is about as high as wide).
cv::Rect windowAround(const cv::Rect& box, const WbDetectorMeta& meta) {
  const double side = box.width / (1 - 2 * meta.margin);
  const double cx = box.x + box.width / 2.0;
  const double cy = (box.y + box.height / 2.0) / meta.aspect;
  return {static_cast<int>(std::lround(cx - side / 2)),
          static_cast<int>(std::lround(cy - side / 2)), static_cast<int>(std::lround(side)),
          static_cast<int>(std::lround(side))};
}

std::string numbered(int i) {
  char name[32];
  std::snprintf(name, sizeof name, "%06d.png", i);
  return name;
}

}  // namespace

void exportWbDetectorData(const fs::path& data, const fs::path& out,
                          const WbDetectorExportParams& params) {
  const auto frames = readDataset(data);
  const DepthTo8BitMap pre{DepthPreprocessParams{}};  // as our models
  for (const auto& view : params.views) {
    // (frame, bowl) pairs of this view that our trainer uses as positives.
    std::vector<std::pair<std::size_t, const BowlAnnotation*>> bowls;
    std::vector<double> aspects;
    for (std::size_t i = 0; i < frames.size(); ++i)
      for (const auto& b : frames[i].bowls)
        if (b.trainable && b.view == view) {
          bowls.emplace_back(i, &b);
          aspects.push_back(static_cast<double>(b.box.height) / b.box.width);
        }
    if (bowls.empty()) throw std::runtime_error("no training bowls for view " + view);
    std::nth_element(aspects.begin(), aspects.begin() + aspects.size() / 2, aspects.end());
    WbDetectorMeta meta;
    meta.aspect = aspects[aspects.size() / 2];
    meta.margin = params.margin;

    const fs::path dir = out / view;
    fs::remove_all(dir);
    fs::create_directories(dir / "pos");
    fs::create_directories(dir / "neg");
    writeWbDetectorMeta(dir / "meta.yml", meta);

    // Evenly spread subset: every k-th bowl (deterministic, covers all scenes and presets).
    const std::size_t n = std::min<std::size_t>(
        bowls.size(), static_cast<std::size_t>(std::max(1, params.max_bowls_per_view)));
    // (dx, dy, mirror) in window pixels, in the order they are added.
    static constexpr int kVariants[10][3] = {{0, 0, 0},  {0, 0, 1},  {1, 0, 0}, {1, 0, 1},
                                             {-1, 0, 0}, {-1, 0, 1}, {0, 1, 0}, {0, 1, 1},
                                             {0, -1, 0}, {0, -1, 1}};
    const int variants = std::clamp(static_cast<int>((params.target_positives + n - 1) / n), 2, 10);
    int written = 0, skipped = 0;
    std::size_t cached_frame = SIZE_MAX;
    cv::Mat stretched;
    for (std::size_t k = 0; k < n; ++k) {
      const auto& [fi, b] = bowls[k * bowls.size() / n];
      if (fi != cached_frame) {
        stretched = stretchForView(preprocessDepth(readDepth(data, frames[fi]), pre), meta);
        cached_frame = fi;
      }
      const cv::Rect w0 = windowAround(b->box, meta);
      const double px = w0.width / static_cast<double>(meta.window);  // one window pixel
      for (int v = 0; v < variants; ++v) {
        const cv::Rect w =
            w0 + cv::Point(cvRound(kVariants[v][0] * px), cvRound(kVariants[v][1] * px));
        if ((w & cv::Rect(0, 0, stretched.cols, stretched.rows)) != w) {
          ++skipped;  // as our trainer: windows reaching out of the image are not used
          continue;
        }
        cv::Mat crop;
        cv::resize(stretched(w), crop, cv::Size(meta.window, meta.window), 0, 0, cv::INTER_AREA);
        if (kVariants[v][2]) cv::flip(crop, crop, 1);
        cv::imwrite((dir / "pos" / numbered(written++)).string(), crop);
      }
    }
    std::vector<cv::Mat> bowl_free;
    for (const auto& f : frames)
      if (f.negative)
        bowl_free.push_back(stretchForView(preprocessDepth(readDepth(data, f), pre), meta));
    if (bowl_free.empty()) throw std::runtime_error("no bowl-free frames in " + data.string());
    // WBDetector's first round takes its negatives as the 24x24 tiles of the first negative
    // images in name order (10 per positive). Tiles of whole depth frames are nearly all flat
    // and a few weak classifiers reject them all (training then stops with no negative left
    // and a classifier that rejects everything; bootstrapping cannot recover). So the folder
    // starts with mosaics of random windows (positions and sizes the detector scans) from the
    // bowl-free frames, as boosting trainers usually draw their first negatives; the frames
    // themselves follow, for its bootstrapping.
    const int tiles_x = 26, tiles_y = 20, W = meta.window;
    const int mosaics = (10 * written + tiles_x * tiles_y - 1) / (tiles_x * tiles_y);
    cv::RNG rng(0x5eed0000u + static_cast<unsigned>(view.size()));
    int negatives = 0;
    for (int k = 0; k < mosaics; ++k) {
      // One spare row and column: WBDetector's tiling loop needs x + 24 < cols.
      cv::Mat mosaic(tiles_y * W + 1, tiles_x * W + 1, CV_8UC1, cv::Scalar(255));
      for (int ty = 0; ty < tiles_y; ++ty)
        for (int tx = 0; tx < tiles_x; ++tx) {
          const cv::Mat& img = bowl_free[static_cast<std::size_t>(
              rng.uniform(0, static_cast<int>(bowl_free.size())))];
          const int side =
              std::min({cvRound(std::exp(rng.uniform(std::log(20.0), std::log(240.0)))), img.cols,
                        img.rows});
          // Row before column, in two statements: in one argument list the compiler would
          // pick the order of the draws, and the mosaics with it.
          const int top = rng.uniform(0, img.rows - side + 1);
          const cv::Rect win(rng.uniform(0, img.cols - side + 1), top, side, side);
          cv::resize(img(win), mosaic(cv::Rect(tx * W, ty * W, W, W)), cv::Size(W, W), 0, 0,
                     cv::INTER_AREA);
        }
      cv::imwrite((dir / "neg" / numbered(negatives++)).string(), mosaic);
    }
    for (const auto& img : bowl_free)
      cv::imwrite((dir / "neg" / numbered(negatives++)).string(), img);
    std::fprintf(stderr,
                 "[%s] aspect %.3f: %d positives (%d variants) from %zu of %zu bowls (%d out of "
                 "the image), %d negative images (%d mosaics)\n",
                 view.c_str(), meta.aspect, written, variants, n, bowls.size(), skipped, negatives,
                 mosaics);
  }
}

}  // namespace shapesense::train
