/// The sealed checkpoint container (io/restart/checkpoint_file.hpp): what a commit writes, and
/// that every kind of damaged file is rejected with a SetupError saying what is wrong, by the
/// verification that runs before any HDF5 call. The messages of the verification never mention
/// HDF5 (HDF5's own failures are reported as "HDF5 file '...': ..."), so a message check also
/// shows that HDF5 was not reached.
#include <catch2/catch.hpp>
#include <hdf5.h>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "engine/core/error.hpp"
#include "io/hdf5/h5file.hpp"
#include "io/restart/checkpoint_file.hpp"
#include "io/restart/hdf5_archive.hpp"
#include "support/scratch.hpp"

namespace test_checkpoint_integrity {

namespace fs = std::filesystem;
using sparkdem::SetupError;
using sparkdem::io::H5File;
using sparkdem::io::Hdf5Archive;
using sparkdem::io::kCheckpointHeaderBytes;

namespace {

std::vector<unsigned char> read_bytes(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  return std::vector<unsigned char>(std::istreambuf_iterator<char>(in), {});
}

void write_bytes(const fs::path& file, const std::vector<unsigned char>& bytes) {
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  REQUIRE(out);
}

/// A small checkpoint with a few items of every kind; returns its path.
fs::path write_checkpoint(const fs::path& dir) {
  const fs::path file = dir / "checkpoint.h5";
  Hdf5Archive out = Hdf5Archive::for_writing(file);
  std::vector<double> positions;
  for (int i = 0; i < 60; ++i) positions.push_back(0.001 * i + 1.0 / 3.0);
  std::vector<std::int64_t> ids{1, 2, 3, 5, 8, 13, 21, 34, 55, 89};
  double time = 0.125;
  std::int64_t step = 1700;
  std::string name = "pour";
  out.visit("state/particles/position", positions, 3);
  out.visit("state/particles/id", ids);
  out.visit("state/time", time);
  out.visit("state/step", step);
  out.visit("state/stage", name);
  out.commit();
  return file;
}

/// The message of the SetupError that reading `file` throws, through the raw verification and
/// through Hdf5Archive (both must throw the same); fails the test if either does not throw.
std::string rejection(const fs::path& file) {
  std::string raw, archive;
  try {
    sparkdem::io::read_verified_checkpoint(file);
    FAIL("read_verified_checkpoint accepted " << file);
  } catch (const SetupError& e) { raw = e.what(); }
  try {
    Hdf5Archive::for_reading(file);
    FAIL("Hdf5Archive::for_reading accepted " << file);
  } catch (const SetupError& e) { archive = e.what(); }
  CHECK(raw == archive);
  CHECK_THAT(raw, Catch::Contains("checkpoint '" + file.string() + "'"));
  CHECK_THAT(raw, !Catch::Contains("HDF5"));
  return raw;
}

}  // namespace

TEST_CASE("FNV-1a 64 matches the published test vectors", "[io][checkpoint]") {
  const auto hash = [](const std::string& s) {
    return sparkdem::io::fnv1a64(std::span(reinterpret_cast<const unsigned char*>(s.data()), s.size()));
  };
  CHECK(hash("") == 0xcbf29ce484222325ULL);
  CHECK(hash("a") == 0xaf63dc4c8601ec8cULL);
  CHECK(hash("foobar") == 0x85944171f73967e8ULL);
  // Continuing from a state is the same as hashing the concatenation.
  const std::string foo = "foo", bar = "bar";
  CHECK(sparkdem::io::fnv1a64(std::span(reinterpret_cast<const unsigned char*>(bar.data()), bar.size()), hash(foo)) == hash("foobar"));
}

TEST_CASE("a committed checkpoint carries its header and stays an ordinary HDF5 file", "[io][checkpoint]") {
  sparkdem::test::ScratchDir dir("sparkdem_ckpt");
  const fs::path file = write_checkpoint(dir.path);
  CHECK_FALSE(fs::exists(dir.path / "checkpoint.h5.tmp"));
  const std::vector<unsigned char> bytes = read_bytes(file);
  REQUIRE(bytes.size() > kCheckpointHeaderBytes);
  const std::uint64_t payload = bytes.size() - kCheckpointHeaderBytes;
  const std::uint64_t checksum = sparkdem::io::fnv1a64(std::span(bytes).subspan(kCheckpointHeaderBytes));
  const std::string header(bytes.begin(), bytes.begin() + kCheckpointHeaderBytes);
  CHECK(header == sparkdem::io::checkpoint_header(payload, checksum));
  char expected[128];
  std::snprintf(expected, sizeof expected, "SPARKDEM-CHECKPOINT v1\npayload-bytes %020llu\nfnv1a64 %016llx\n",
                static_cast<unsigned long long>(payload), static_cast<unsigned long long>(checksum));
  CHECK(header.substr(0, std::strlen(expected)) == expected);
  CHECK(header.find_first_not_of('\0', std::strlen(expected)) == std::string::npos);
  // HDF5's superblock follows the user block: the payload starts with the HDF5 signature.
  CHECK(std::memcmp(bytes.data() + kCheckpointHeaderBytes, "\x89HDF\r\n\x1a\n", 8) == 0);

  // The verification returns the file's bytes unchanged.
  CHECK(sparkdem::io::read_verified_checkpoint(file) == bytes);

  // Plain HDF5 (the sec2 driver, as h5dump or h5py use) opens it and reports the user block.
  const H5File plain = H5File::open_read(file);
  CHECK(plain.read_int64("state/step") == 1700);
  const hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  REQUIRE(f >= 0);
  const hid_t fcpl = H5Fget_create_plist(f);
  hsize_t userblock = 0;
  CHECK(H5Pget_userblock(fcpl, &userblock) >= 0);
  CHECK(userblock == kCheckpointHeaderBytes);
  H5Pclose(fcpl);
  H5Fclose(f);

  // The fallback without /proc: HDF5's core driver reads the verified image in place, no copy.
  {
    std::vector<unsigned char> image = sparkdem::io::read_verified_checkpoint(file);
    const unsigned char* buffer = image.data();
    const H5File mem = H5File::open_image(file, image);
    CHECK(mem.read_int64("state/step") == 1700);
    CHECK(mem.read_doubles("state/particles/position") == plain.read_doubles("state/particles/position"));
    CHECK(image.data() == buffer);
    CHECK(image == bytes);  // read-only: the caller's buffer is untouched
  }

  // And the archive reads it back through the verified descriptor.
  Hdf5Archive in = Hdf5Archive::for_reading(file);
  std::int64_t step = 0;
  std::string stage;
  std::vector<std::int64_t> ids;
  in.visit("state/step", step);
  in.visit("state/stage", stage);
  in.visit("state/particles/id", ids);
  CHECK(step == 1700);
  CHECK(stage == "pour");
  CHECK(ids == std::vector<std::int64_t>{1, 2, 3, 5, 8, 13, 21, 34, 55, 89});
}

TEST_CASE("truncated, corrupt, empty and foreign checkpoints are rejected before HDF5 parses them", "[io][checkpoint]") {
  sparkdem::test::ScratchDir dir("sparkdem_ckpt");
  const fs::path good = write_checkpoint(dir.path);
  const std::vector<unsigned char> bytes = read_bytes(good);
  const std::size_t size = bytes.size();
  const std::size_t expected_size = size;
  const fs::path bad = dir.path / "bad.h5";

  SECTION("truncated") {
    for (const std::size_t n : {std::size_t{1}, std::size_t{10}, std::size_t{200}, kCheckpointHeaderBytes - 1}) {
      write_bytes(bad, std::vector<unsigned char>(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(n)));
      CHECK_THAT(rejection(bad), Catch::Contains("is truncated: " + std::to_string(n) + " bytes, shorter than its 512-byte header"));
    }
    for (const std::size_t n : {kCheckpointHeaderBytes, kCheckpointHeaderBytes + 8, size / 2, size - 1}) {
      write_bytes(bad, std::vector<unsigned char>(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(n)));
      CHECK_THAT(rejection(bad),
                 Catch::Contains("is truncated: " + std::to_string(n) + " bytes, its header says " + std::to_string(expected_size)));
    }
  }
  SECTION("one flipped byte in the middle") {
    std::vector<unsigned char> flipped = bytes;
    flipped[size / 2] ^= 0x01;
    write_bytes(bad, flipped);
    CHECK_THAT(rejection(bad), Catch::Contains("is corrupt: checksum mismatch"));
  }
  SECTION("any single damaged byte anywhere in the file") {
    // FNV-1a detects every single-byte change of the payload; the header is checked field by
    // field. Every position, with a 1-bit and an 8-bit change, patched in place (rewriting the
    // whole file each time is slow on ext4, which flushes files replaced by truncation).
    write_bytes(bad, bytes);
    std::fstream patch(bad, std::ios::in | std::ios::out | std::ios::binary);
    REQUIRE(patch);
    std::size_t rejected = 0;
    for (std::size_t pos = 0; pos < size; ++pos) {
      for (const unsigned char mask : {0x01, 0xff}) {
        const auto poke = [&](unsigned char value) {
          patch.seekp(static_cast<std::streamoff>(pos));
          patch.put(static_cast<char>(value));
          patch.flush();
          REQUIRE(patch);
        };
        poke(static_cast<unsigned char>(bytes[pos] ^ mask));
        try {
          sparkdem::io::read_verified_checkpoint(bad);
        } catch (const SetupError& e) {
          const std::string what = e.what();
          if (what.find("HDF5") == std::string::npos) ++rejected;
        }
        poke(bytes[pos]);
      }
    }
    CHECK(rejected == 2 * size);
    CHECK(sparkdem::io::read_verified_checkpoint(bad) == bytes);  // restored: accepted again
  }
  SECTION("zero-length file") {
    write_bytes(bad, {});
    CHECK_THAT(rejection(bad), Catch::Contains("is empty (0 bytes)"));
  }
  SECTION("random bytes") {
    std::mt19937 rng(20240531);
    std::vector<unsigned char> noise(4096);
    for (auto& b : noise) b = static_cast<unsigned char>(rng() & 0xff);
    write_bytes(bad, noise);
    CHECK_THAT(rejection(bad), Catch::Contains("is not a sparkdem checkpoint"));
  }
  SECTION("an HDF5 file without the header (an unsealed tmp file, or an old checkpoint)") {
    {
      H5File f = H5File::create(bad, kCheckpointHeaderBytes);
      f.write_scalar("x", 1.0);
      f.close();
    }
    CHECK_THAT(rejection(bad), Catch::Contains("is incomplete: its header is blank"));
    {
      H5File f = H5File::create(bad);
      f.write_scalar("x", 1.0);
      f.close();
    }
    CHECK_THAT(rejection(bad), Catch::Contains("is not a sparkdem checkpoint"));
  }
  SECTION("extra bytes after the end") {
    std::vector<unsigned char> longer = bytes;
    longer.push_back(0);
    write_bytes(bad, longer);
    CHECK_THAT(rejection(bad),
               Catch::Contains("is corrupt: " + std::to_string(size + 1) + " bytes, its header says " + std::to_string(size)));
  }
  SECTION("another format version") {
    std::vector<unsigned char> v2 = bytes;
    v2[std::strlen("SPARKDEM-CHECKPOINT v")] = '2';
    write_bytes(bad, v2);
    CHECK_THAT(rejection(bad), Catch::Contains("has the unsupported format 'SPARKDEM-CHECKPOINT v2'"));
  }
  SECTION("damaged header fields and padding") {
    std::vector<unsigned char> damaged = bytes;
    damaged[std::strlen("SPARKDEM-CHECKPOINT v1\npayload-bytes 0")] = 'x';
    write_bytes(bad, damaged);
    CHECK_THAT(rejection(bad), Catch::Contains("has a damaged header: no valid 'payload-bytes ' line"));
    damaged = bytes;
    damaged[kCheckpointHeaderBytes - 1] = ' ';
    write_bytes(bad, damaged);
    CHECK_THAT(rejection(bad), Catch::Contains("has a damaged header: its padding is not all zero bytes"));
  }
  SECTION("a missing file") { CHECK_THAT(rejection(dir.path / "nope.h5"), Catch::Contains("does not exist")); }
  SECTION("a directory") { CHECK_THAT(rejection(dir.path), Catch::Contains("is not a regular file")); }
}

TEST_CASE("a correctly sealed file whose data is not HDF5 fails cleanly in HDF5", "[io][checkpoint]") {
  // The checksum proves the bytes are the ones written, not that they are HDF5: a sealed file
  // of noise passes verification and HDF5 then refuses it (no signature) with a SetupError.
  sparkdem::test::ScratchDir dir("sparkdem_ckpt");
  std::mt19937 rng(7);
  std::vector<unsigned char> noise(3000);
  for (auto& b : noise) b = static_cast<unsigned char>(rng() & 0xff);
  const std::string header = sparkdem::io::checkpoint_header(noise.size(), sparkdem::io::fnv1a64(noise));
  std::vector<unsigned char> file(header.begin(), header.end());
  file.insert(file.end(), noise.begin(), noise.end());
  const fs::path path = dir.path / "noise.h5";
  write_bytes(path, file);
  CHECK(sparkdem::io::read_verified_checkpoint(path) == file);
  try {
    Hdf5Archive::for_reading(path);
    FAIL("a file of noise was opened as a checkpoint");
  } catch (const SetupError& e) { CHECK_THAT(e.what(), Catch::Contains("HDF5 file '" + path.string() + "': cannot open the file")); }
  CHECK(H5Fget_obj_count(H5F_OBJ_ALL, H5F_OBJ_ALL) == 0);
}

}  // namespace test_checkpoint_integrity
