// `glam vocab train | info`: offline training of the vocabulary tree that thread 2 uses to find
// submaps seeing the same ground, and a look inside a vocabulary file. Training extracts
// features exactly as `glam map` does (processing size, SiftOptions defaults, RootSIFT,
// uint8 quantisation), because words learned from other descriptors would not fit the
// descriptors the map stores.
#include <algorithm>
#include <chrono>
#include <filesystem>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>

#include "engine/alignment/vocabulary_tree.h"
#include "engine/core/error.h"
#include "engine/core/logging.h"
#include "engine/features/sift_extractor.h"
#include "engine/submap/frame_record.h"
#include "engine/video/frame_source.h"
#include "engine/video/image_folder_source.h"
#include "server/commands.h"

namespace glam::cli {
namespace {

namespace fs = std::filesystem;

struct TrainArgs {
  std::vector<std::string> inputs;
  std::string out;
  int frames_per_input = 60;
  int max_image_size = FrameSourceOptions{}.max_image_size;
  std::string description;
  VocabularyTreeOptions tree;
};

// Descriptors of each image, one document per image, extracted in parallel.
std::vector<std::vector<Descriptor>> ExtractDocuments(const std::vector<cv::Mat>& images) {
  std::vector<std::vector<Descriptor>> documents(images.size());
  cv::parallel_for_(cv::Range(0, static_cast<int>(images.size())), [&](const cv::Range& range) {
    const SiftExtractor extractor{SiftOptions{}};
    for (int i = range.start; i < range.end; ++i) {
      documents[i] = CompactFeatures::From(extractor.Extract(images[i])).descriptors;
    }
  });
  return documents;
}

// Up to `frames` frames spread evenly over a video or image folder, or the one image of an
// image file, at processing size.
std::vector<cv::Mat> SampleFrames(const fs::path& input, int frames, int max_image_size) {
  if (!fs::exists(input)) throw InputError(fmt::format("input {} does not exist", input.string()));
  if (fs::is_regular_file(input) && HasImageExtension(input)) {
    cv::Mat image = cv::imread(input.string(), cv::IMREAD_COLOR);
    if (image.empty()) throw InputError(fmt::format("cannot decode image {}", input.string()));
    return {ToProcessingSize(image, ProcessingSize(image.size(), max_image_size))};
  }
  FrameSourceOptions options;
  options.max_image_size = max_image_size;
  const FrameSourceInfo info = ProbeVideo(input, options);
  if (info.frame_count > frames) options.stride = static_cast<int>(info.frame_count / frames);
  auto source = OpenFrameSource(input, options);
  std::vector<cv::Mat> out;
  while (static_cast<int>(out.size()) < frames) {
    std::optional<Frame> frame = source->Next();
    if (!frame) break;
    out.push_back(std::move(frame->bgr));
  }
  if (out.empty()) throw InputError(fmt::format("no frames could be read from {}", input.string()));
  return out;
}

void RunTrain(const TrainArgs& args) {
  args.tree.Check();
  if (args.frames_per_input < 1) throw InputError("--frames-per-input must be >= 1");
  const auto start = std::chrono::steady_clock::now();
  std::vector<std::vector<Descriptor>> documents;
  std::size_t descriptors = 0;
  for (const std::string& input : args.inputs) {
    const std::vector<cv::Mat> frames = SampleFrames(input, args.frames_per_input, args.max_image_size);
    // Extract in batches so that a long list of 4K frames is never all in memory at once.
    constexpr std::size_t kBatch = 16;
    for (std::size_t b = 0; b < frames.size(); b += kBatch) {
      const std::vector<cv::Mat> batch(frames.begin() + static_cast<std::ptrdiff_t>(b),
                                       frames.begin() + static_cast<std::ptrdiff_t>(std::min(frames.size(), b + kBatch)));
      for (auto& doc : ExtractDocuments(batch)) {
        descriptors += doc.size();
        if (!doc.empty()) documents.push_back(std::move(doc));
      }
    }
    GLAM_LOG_INFO("vocab: {}: {} frames, {} documents / {} descriptors so far", input, frames.size(),
                  documents.size(), descriptors);
  }
  const double extract_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  VocabularyTree tree = VocabularyTree::Train(documents, args.tree);
  std::string description = args.description;
  if (description.empty()) {
    std::vector<std::string> names;
    for (const std::string& input : args.inputs) names.push_back(fs::path(input).filename().string());
    description = fmt::format("glam vocab train, {} frames per input, max image size {}: {}",
                              args.frames_per_input, args.max_image_size, fmt::join(names, ", "));
  }
  tree.set_description(description);
  const fs::path out(args.out);
  if (out.has_parent_path()) fs::create_directories(out.parent_path());
  tree.Save(out);
  const double total_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::cerr << fmt::format(
      "glam vocab: {} words ({} nodes) from {} documents / {} descriptors; features {:.1f} s, "
      "total {:.1f} s -> {} ({} bytes)\n",
      tree.num_words(), tree.num_nodes(), documents.size(), descriptors, extract_s, total_s, out.string(),
      fs::file_size(out));
}

void RunInfo(const std::string& path) {
  const auto start = std::chrono::steady_clock::now();
  const VocabularyTree tree = path == "default" ? VocabularyTree::Default() : VocabularyTree::Load(path);
  const double load_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  int zero_idf = 0;
  double idf_sum = 0;
  for (int w = 0; w < tree.num_words(); ++w) {
    zero_idf += tree.idf(static_cast<std::uint32_t>(w)) == 0 ? 1 : 0;
    idf_sum += tree.idf(static_cast<std::uint32_t>(w));
  }
  std::cout << fmt::format(
      "file: {}\nwords: {}\nnodes: {}\nbranching: {}\ndepth: {}\nkmeans iterations: {}\nseed: {}\n"
      "training documents: {}\ntraining descriptors: {}\nmean idf: {:.3f} ({} words with idf 0)\n"
      "description: {}\nload time: {:.1f} ms\n",
      path, tree.num_words(), tree.num_nodes(), tree.branching(), tree.depth(), tree.kmeans_iterations(),
      tree.seed(), tree.training_documents(), tree.training_descriptors(),
      tree.num_words() > 0 ? idf_sum / tree.num_words() : 0.0, zero_idf, tree.description(), load_ms);
}

}  // namespace

void RegisterVocabCommand(CLI::App& app) {
  CLI::App* vocab = app.add_subcommand(
      "vocab", "Train or inspect the vocabulary tree used to find submaps that see the same ground");
  vocab->require_subcommand(1);

  auto args = std::make_shared<TrainArgs>();
  CLI::App* train = vocab->add_subcommand(
      "train",
      "Train a vocabulary tree (hierarchical k-means of SIFT descriptors, tf-idf weights) from videos "
      "and images. Frames are sampled evenly from every input and described exactly as `glam map` "
      "does; each frame is one training document for the idf weights. Use imagery that resembles "
      "the flights to be mapped but is not a test's expected answer.");
  train->add_option("inputs", args->inputs, "Video files, image files or folders of images")
      ->required()
      ->expected(1, -1);
  train->add_option("--out", args->out, "Vocabulary file to write (e.g. vocab.bin)")->required();
  train->add_option("--branching", args->tree.branching, "Children per node (k of each k-means)")
      ->capture_default_str();
  train->add_option("--depth", args->tree.depth, "Levels below the root: up to branching^depth words")
      ->capture_default_str();
  train->add_option("--iterations", args->tree.kmeans_iterations, "k-means iterations per node")
      ->capture_default_str();
  train->add_option("--frames-per-input", args->frames_per_input,
                    "Frames sampled evenly from each video or folder")
      ->capture_default_str();
  train->add_option("--max-descriptors", args->tree.max_training_descriptors,
                    "Descriptors used for clustering (random subset; all count for idf)")
      ->capture_default_str();
  train->add_option("--max-image-size", args->max_image_size,
                    "Downscale frames to this long side (px) as `glam map` does; 0 = never")
      ->capture_default_str();
  train->add_option("--seed", args->tree.seed, "Seed of k-means++ and subsampling (same seed, same tree)")
      ->capture_default_str();
  train->add_option("--description", args->description,
                    "Text stored in the file (default: the options and input names)");
  train->callback([args] { RunTrain(*args); });

  auto info_path = std::make_shared<std::string>();
  CLI::App* info = vocab->add_subcommand(
      "info", "Print the size and training parameters of a vocabulary file ('default' = the built-in one)");
  info->add_option("file", *info_path, "Vocabulary file, or 'default'")->required();
  info->callback([info_path] { RunInfo(*info_path); });
}

}  // namespace glam::cli
