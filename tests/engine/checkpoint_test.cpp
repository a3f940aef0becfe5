#include "fskin/engine/checkpoint.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include <filesystem>
#include <fstream>

#include "fskin/util/atomic_file.h"
#include "test_util.h"

namespace fskin {
namespace {

namespace fs = std::filesystem;

fs::path fresh_dir(const std::string& name) {
  const auto dir = fs::temp_directory_path() / ("fskin_ckpt_" + name + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

ArchiveWriter write_value(float value, int64_t step) {
  return [=](torch::serialize::OutputArchive& a) {
    a.write("value", torch::full({3}, value));
    a.write("step", torch::tensor(step));
  };
}

float read_value(const fs::path& dir) {
  float value = -1;
  load_latest_checkpoint(dir.string(), [&](torch::serialize::InputArchive& a) {
    torch::Tensor t;
    a.read("value", t);
    value = t[0].item<float>();
  });
  return value;
}

TEST(Checkpoint, SavesKeepsNewestAndLoadsLatest) {
  const auto dir = fresh_dir("keep");
  for (int step = 1; step <= 4; ++step) save_checkpoint(dir.string(), step * 10, write_value(step, step), 2);
  const auto files = list_checkpoints(dir.string());
  ASSERT_EQ(files.size(), 2u);
  EXPECT_NE(files[0].find("checkpoint-00000040"), std::string::npos);
  EXPECT_FLOAT_EQ(read_value(dir), 4.0f);
  for (const auto& entry : fs::directory_iterator(dir))  // no temporary files left
    EXPECT_EQ(entry.path().filename().string().find(".tmp-"), std::string::npos);
}

TEST(Checkpoint, TruncatedNewestFallsBackToPrevious) {
  const auto dir = fresh_dir("trunc");
  save_checkpoint(dir.string(), 1, write_value(1.0f, 1));
  const auto newest = save_checkpoint(dir.string(), 2, write_value(2.0f, 2));
  const auto bytes = read_file(newest);
  write_file_atomically(newest, bytes.substr(0, bytes.size() / 2));
  EXPECT_THROW(read_checkpoint_payload(newest), std::runtime_error);
  EXPECT_FLOAT_EQ(read_value(dir), 1.0f);
}

TEST(Checkpoint, CorruptedByteIsDetected) {
  const auto dir = fresh_dir("crc");
  const auto path = save_checkpoint(dir.string(), 5, write_value(5.0f, 5));
  auto bytes = read_file(path);
  bytes[bytes.size() - 10] ^= 0x5a;
  write_file_atomically(path, bytes);
  try {
    read_checkpoint_payload(path);
    FAIL() << "expected a CRC error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("CRC"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
  EXPECT_FLOAT_EQ(read_value(dir), -1.0f);  // nothing intact to load
}

TEST(Checkpoint, IntactCheckpointThatDoesNotFitIsAnErrorNotDamage) {
  // Falling back to an older checkpoint here would silently drop training.
  const auto dir = fresh_dir("misfit");
  save_checkpoint(dir.string(), 1, write_value(1.0f, 1));
  const auto newest = save_checkpoint(dir.string(), 2, write_value(2.0f, 2));
  testing::expect_error(
      [&] {
        load_latest_checkpoint(dir.string(), [](torch::serialize::InputArchive& a) {
          torch::Tensor t;
          a.read("a_key_this_version_does_not_write", t);
        });
      },
      {newest, "intact checkpoint that does not fit this model", "a_key_this_version_does_not_write"});
}

TEST(Checkpoint, MissingDirectoryHasNoCheckpoints) {
  EXPECT_TRUE(list_checkpoints("/nonexistent/fskin/dir").empty());
}

TEST(CheckpointChoice, ParsesLatestBestAndSteps) {
  EXPECT_EQ(CheckpointChoice::parse("latest").kind, CheckpointChoice::Kind::Latest);
  EXPECT_EQ(CheckpointChoice::parse("best").kind, CheckpointChoice::Kind::Best);
  const auto step = CheckpointChoice::parse("1200");
  EXPECT_EQ(step.kind, CheckpointChoice::Kind::Step);
  EXPECT_EQ(step.step, 1200);
  EXPECT_EQ(step.describe(), "step 1200");
  for (const auto* bad : {"", "-3", "12a", "newest", "99999999999999999999"}) {
    testing::expect_error([&] { CheckpointChoice::parse(bad); }, {"--checkpoint", "'" + std::string(bad) + "'"});
  }
}

TEST(CheckpointChoice, FindsTheNamedFileOrListsWhatThereIs) {
  const auto dir = fresh_dir("choice");
  save_checkpoint(dir.string(), 10, write_value(1, 10), 3);
  save_checkpoint(dir.string(), 20, write_value(2, 20), 3);
  EXPECT_EQ(*find_checkpoint(dir.string(), {}), (dir / "checkpoint-00000020.fskin").string());
  EXPECT_EQ(*find_checkpoint(dir.string(), CheckpointChoice::parse("10")), (dir / "checkpoint-00000010.fskin").string());
  testing::expect_error([&] { find_checkpoint(dir.string(), CheckpointChoice::parse("30")); },
                        {dir.string(), "step 30", "20, 10"});
  testing::expect_error([&] { find_checkpoint(dir.string(), CheckpointChoice::parse("best")); },
                        {"no best checkpoint", "validate_every"});
  write_checkpoint_file(best_checkpoint_path(dir.string()), write_value(7, 10));
  EXPECT_EQ(*find_checkpoint(dir.string(), CheckpointChoice::parse("best")), best_checkpoint_path(dir.string()));
  // The best file is outside the numbered rotation: saving more steps keeps it.
  save_checkpoint(dir.string(), 30, write_value(3, 30), 1);
  EXPECT_TRUE(fs::exists(best_checkpoint_path(dir.string())));
  EXPECT_EQ(list_checkpoints(dir.string()).size(), 1u);
  float value = -1;
  load_checkpoint(best_checkpoint_path(dir.string()), [&](torch::serialize::InputArchive& a) {
    torch::Tensor t;
    a.read("value", t);
    value = t[0].item<float>();
  });
  EXPECT_EQ(value, 7.0f);
  EXPECT_FALSE(find_checkpoint(fresh_dir("choice_empty").string(), {}).has_value());
}

}  // namespace
}  // namespace fskin
