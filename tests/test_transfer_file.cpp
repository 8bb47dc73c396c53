// Tests of the one transfer type (prt/transfer_file.h): every kind the
// commands make reads back as its kind through read_transfer_file and writes
// back to the same bytes; the typed readers refuse other kinds by name; a
// probe volume of the format before the shared framing is refused by name;
// the consumer table's refusals are sentences, the commands say them, and
// docs/ARCHITECTURE.md shows the table as the code has it.
#include "test_files.h"

#include <prt/error.h>
#include <prt/transfer_file.h>
#include <prt/transfer_io.h>

#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;
using namespace prt::test;
using prt::Consumer;
using prt::TransferKind;

const std::string kTube = std::string(PRT_SOURCE_DIR) + "/models/tube.obj";
const std::string kRoom = std::string(PRT_SOURCE_DIR) + "/models/room.gltf";
const std::string kEnv = std::string(PRT_SOURCE_DIR) + "/envmaps/sunset.exr";

struct KindFile {
  TransferKind kind;
  std::string name;
  std::vector<std::string> args;  // prt precompute / compress, writing `name`
};

// One small file of each kind, made by the command as a user makes it.
const std::vector<KindFile>& kind_files() {
  static const std::vector<KindFile> files = {
      {TransferKind::SH, "sh.prt", {"precompute", kTube, "--mode", "interreflected", "--samples", "32"}},
      {TransferKind::Compressed, "c.prt", {"compress", "sh.prt", "-k", "8", "-n", "2"}},
      {TransferKind::Wavelet, "w.prt", {"precompute", kTube, "--basis", "wavelet", "--cube-res", "4"}},
      {TransferKind::ZH, "zh.prt", {"precompute", kTube, "--basis", "zh", "--samples", "32", "--lobes", "2"}},
      {TransferKind::Lightmap, "lm.prt", {"precompute", kRoom, "--lightmap", "16x16", "--samples", "16"}},
      {TransferKind::WaveletLightmap,
       "wlm.prt",
       {"precompute", kRoom, "--lightmap", "16x16", "--basis", "wavelet", "--cube-res", "4"}},
      {TransferKind::Probes, "p.prt", {"precompute", kRoom, "--probes", "2x2x2", "--probe-cube", "4", "--samples", "8"}},
  };
  return files;
}

// The files, made once per test process (ctest runs each test alone).
struct Made {
  TempDir dir;
  Made() {
    for (const KindFile& f : kind_files()) {
      std::vector<std::string> args = f.args;
      args.insert(args.end(), {"-o", dir.file(f.name), "-q"});
      for (std::string& a : args)
        if (a == "sh.prt") a = dir.file("sh.prt");
      const Result r = run_prt(dir, args);
      if (r.code != 0) ADD_FAILURE() << f.name << ": " << describe_run(r);
    }
  }
};

const TempDir& made() {
  static const Made m;
  return m.dir;
}

// kind_files() holds a file of every kind: a new kind fails here until its
// reader, writer and size are exercised by one.
TEST(TransferFile, EveryKindReadsAsItsKindAndWritesBackTheSameBytes) {
  const TempDir& d = made();
  std::vector<bool> seen(prt::kTransferKinds, false);
  for (const KindFile& f : kind_files()) seen[std::size_t(f.kind)] = true;
  for (std::size_t k = 0; k < prt::kTransferKinds; ++k)
    EXPECT_TRUE(seen[k]) << "no file of kind " << prt::kind_names(prt::TransferKind(k)).id << " in kind_files()";
  for (const KindFile& f : kind_files()) {
    SCOPED_TRACE(f.name);
    std::uint32_t version = 0;
    const prt::AnyTransfer any = prt::read_transfer_file(d.file(f.name), &version);
    EXPECT_EQ(prt::kind_of(any), f.kind) << prt::kind_names(prt::kind_of(any)).id;
    EXPECT_GE(version, 1u);
    const std::string copy = d.file("copy-" + f.name);
    prt::write_transfer_file(copy, any);
    EXPECT_EQ(read_file(copy), read_file(d.file(f.name)));
    EXPECT_EQ(prt::file_size(any), fs::file_size(d.file(f.name)));
    EXPECT_FALSE(prt::describe(any).empty());
  }
}

TEST(TransferFile, TypedReaderRefusesAnotherKindNamingBoth) {
  const TempDir& d = made();
  try {
    (void)prt::read_transfer_as<prt::ProbeTransfer>(d.file("sh.prt"));
    FAIL() << "read an SH transfer as a probe volume";
  } catch (const prt::Error& e) {
    EXPECT_NE(std::string(e.what()).find("holds an SH transfer (prt precompute MESH), not a probe volume"),
              std::string::npos)
        << e.what();
  }
  EXPECT_EQ(prt::read_transfer_as<prt::ZhTransfer>(d.file("zh.prt")).lobes, 2);
}

TEST(TransferFile, ProbeVolumeOfTheOldFormatIsRefusedByName) {
  TempDir d;
  // The signature of the format probe volumes had before they joined the
  // transfer format, then bytes of no matter.
  write_file(d.file("old.prt"), std::string("PRTP\r\n\x1a\n", 8) + std::string(200, '\0'));
  try {
    (void)prt::read_transfer_file(d.file("old.prt"));
    FAIL() << "read an old probe volume";
  } catch (const prt::Error& e) {
    EXPECT_NE(std::string(e.what()).find("made by an older prt"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("precompute it again"), std::string::npos) << e.what();
  }
}

TEST(TransferFile, DamagedProbeVolumeIsRefused) {
  const TempDir& d = made();
  const std::string good = read_file(d.file("p.prt"));
  TempDir t;
  // A flipped data byte: the checksum; a cut: the trailer.
  std::string flipped = good;
  flipped[200] = char(flipped[200] ^ 0x40);
  write_file(t.file("flipped.prt"), flipped);
  EXPECT_THROW((void)prt::read_transfer_file(t.file("flipped.prt")), prt::Error);
  write_file(t.file("cut.prt"), good.substr(0, good.size() - 40));
  EXPECT_THROW((void)prt::read_transfer_file(t.file("cut.prt")), prt::Error);
}

TEST(ConsumerTable, EveryRefusalIsASentenceAndRequireSupportSaysIt) {
  for (std::size_t k = 0; k < prt::kTransferKinds; ++k)
    for (std::size_t c = 0; c < prt::kConsumers; ++c) {
      const auto kind = TransferKind(k);
      const auto consumer = Consumer(c);
      const prt::Support& s = prt::support(kind, consumer);
      SCOPED_TRACE(std::string(prt::kind_names(kind).id) + " x " + std::string(prt::consumer_name(consumer)));
      ASSERT_FALSE(s.why.empty());
      if (s.works) {
        EXPECT_NO_THROW(prt::require_support(kind, consumer, "FILE"));
      } else {
        try {
          prt::require_support(kind, consumer, "FILE");
          ADD_FAILURE() << "no refusal";
        } catch (const prt::Error& e) {
          EXPECT_EQ(std::string(e.what()), "FILE: " + std::string(s.why));
        }
        // A refusal says what to do instead: a command (prt X), a Python function (prt.x) or an option to use
        // or leave out.
        EXPECT_TRUE(s.why.find("prt ") != std::string_view::npos || s.why.find("prt.") != std::string_view::npos ||
                    s.why.find("--") != std::string_view::npos)
            << s.why;
      }
    }
}

// The commands refuse a kind they do not take with the table's sentence.
TEST(ConsumerTable, CommandsRefuseWithTheTablesSentence) {
  const TempDir& d = made();
  struct Case {
    TransferKind kind;
    Consumer consumer;
    std::vector<std::string> args;
  };
  const std::vector<Case> cases = {
      {TransferKind::Probes, Consumer::Render,
       {"render", kRoom, d.file("p.prt"), kEnv, "-o", d.file("x.png"), "--width", "8", "--height", "8"}},
      {TransferKind::WaveletLightmap, Consumer::Render,
       {"render", kRoom, d.file("wlm.prt"), kEnv, "-o", d.file("x.png"), "--width", "8", "--height", "8"}},
      {TransferKind::Compressed, Consumer::Compress, {"compress", d.file("c.prt"), "-o", d.file("x.prt")}},
      {TransferKind::Wavelet, Consumer::ExportGlb, {"export", kTube, d.file("w.prt"), "-o", d.file("x.glb")}},
      {TransferKind::ZH, Consumer::Compress, {"compress", d.file("zh.prt"), "-o", d.file("x.prt")}},
  };
  for (const Case& c : cases) {
    const std::string why(prt::support(c.kind, c.consumer).why);
    SCOPED_TRACE(why);
    ASSERT_FALSE(prt::support(c.kind, c.consumer).works);
    const Result r = run_prt(d, c.args);
    EXPECT_EQ(r.code, 1) << describe_run(r);
    EXPECT_NE(r.err.find(why), std::string::npos) << describe_run(r);
  }
}

TEST(ConsumerTable, PrtInfoKindsPrintsIt) {
  TempDir d;
  const Result r = run_prt(d, {"info", "--kinds"});
  EXPECT_EQ(r.code, 0) << describe_run(r);
  EXPECT_EQ(r.out, prt::support_table_markdown());
  // The table alone: with a file, or without either, a usage error.
  EXPECT_EQ(run_prt(d, {"info", "--kinds", kTube}).code, 2);
  EXPECT_EQ(run_prt(d, {"info"}).code, 2);
}

TEST(ConsumerTable, ArchitectureDocShowsTheTable) {
  const std::string doc = read_file(fs::path(PRT_SOURCE_DIR) / "docs" / "ARCHITECTURE.md");
  EXPECT_NE(doc.find(prt::support_table_markdown()), std::string::npos)
      << "docs/ARCHITECTURE.md should hold the table as prt::support_table_markdown() prints it:\n"
      << prt::support_table_markdown();
}

}  // namespace
