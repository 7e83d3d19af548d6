/// sparkdem_fuzz: seeded mutation fuzzing at scale, every case in a forked child process with a
/// time limit and an address-space limit, so crashes and hangs are seen and classified.
///
///   sparkdem_fuzz loader     --cases N [--seed S] [--work DIR] [--out FILE.json] [--time-limit SEC]
///   sparkdem_fuzz checkpoint --cases N [--seed S] [--work DIR] [--out FILE.json] [--time-limit SEC]
///   ... --only K   replays case K alone (same seed) and prints its recipe and outcome
///
/// loader: every configs/**/*.json and tests/scenario/data/*.json, mutated by
///   test::JsonMutator::mutate_extended (1 to 3 mutations) or truncated, through io::load_scenario
///   (base directory: the file's own). Expected outcomes: loaded, ConfigError, SetupError (or the
///   text no longer parses, counted before any load).
/// checkpoint: a genuine checkpoint of each seed scene (taken 40 steps before the end of its last
///   stage, so a restart has little left to run) is mutated (test::CheckpointMutator: 3 in 4
///   structure-aware, 1 in 4 byte-level), re-sealed with a valid checksum header and given to
///   io::run_scenario with RunOptions::restart (the path of `sparkdem run --restart`): the
///   checkpoint is read, the state restored, the run continued to its end and every output written.
///   Expected outcomes: completed, SetupError (exit code 4), PhysicsError (exit code 3).
/// Anything else is a bug: another exception (std::bad_alloc, std::out_of_range, ...), a crash
/// (signal) or a hang (time limit). Inputs of bug cases are kept in WORK/bugs/.
///
/// The counts go to --out as JSON (and a summary to stdout). Run single-threaded (the driver sets
/// one OpenMP thread; it forks, so it must not start OpenMP workers itself).
#include <fcntl.h>
#include <omp.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <optional>
#include <sstream>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "engine/core/error.hpp"
#include "engine/model/registry.hpp"
#include "io/scenario/pipeline.hpp"
#include "io/scenario/scenario.hpp"
#include "physics/register_all.hpp"
#include "support/checkpoint_fuzz.hpp"
#include "support/checkpoint_mutator.hpp"
#include "support/child_process.hpp"
#include "support/json_mutator.hpp"
#include "support/mock_modules.hpp"

namespace sparkdem::test {
Registry registry_with_mocks() {
  Registry r;
  physics::register_all(r);
  r.module<MockModule<0>>();
  r.module<MockModule<1>>();
  r.module<MockModule<2>>();
  r.module<MockNetwork>();
  return r;
}
}  // namespace sparkdem::test

namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using namespace sparkdem;
using test::ChildResult;
namespace fuzz = test::fuzz;
using fuzz::class_name;
using fuzz::classify;
using fuzz::is_bug;
using fuzz::kAddressSpace;

const Registry& registry() {
  static const Registry reg = test::registry_with_mocks();
  return reg;
}

struct Options {
  std::string mode;
  long long cases = 1000;
  unsigned long long seed = 1;
  fs::path work;
  fs::path out;
  unsigned time_limit = 20;
  long long only = -1;
  double max_seconds = 0.0;  ///< loader: stop (and report) after this wall time, 0 = no limit
  fs::path source = SPARKDEM_SOURCE_DIR;
};

struct Tally {
  std::map<std::string, long long> outcomes;
  std::map<std::string, std::map<std::string, long long>> by_seed;
  json bugs = json::array();
  long long cases = 0;
  double slowest = 0.0;
  void add(const std::string& seed, const ChildResult& r) {
    const std::string c = class_name(r);
    ++outcomes[c];
    ++by_seed[seed][c];
    ++cases;
    slowest = std::max(slowest, r.seconds);
  }
};

void write_report(const Options& o, const Tally& t, double seconds, const json& extra) {
  json j = extra;
  j["mode"] = o.mode;
  j["cases"] = t.cases;
  j["seed"] = o.seed;
  j["time_limit_s"] = o.time_limit;
  j["wall_time_s"] = seconds;
  j["slowest_case_s"] = t.slowest;
  j["outcomes"] = t.outcomes;
  j["by_seed"] = t.by_seed;
  j["bugs"] = t.bugs;
  long long bugs = 0;
  for (const auto& b : t.bugs) (void)b, ++bugs;
  j["bug_count"] = bugs;
  if (!o.out.empty()) std::ofstream(o.out) << j.dump(2) << "\n";
  std::cout << o.mode << ": " << t.cases << " cases in " << seconds << " s, outcomes " << json(t.outcomes).dump() << ", bugs " << bugs
            << "\n";
}

// ---------------------------------------------------------------------------------------------
// Loader

std::vector<fs::path> loader_seeds(const fs::path& src) {
  std::vector<fs::path> files;
  for (const auto& e : fs::recursive_directory_iterator(src / "configs"))
    if (e.path().extension() == ".json") files.push_back(e.path());
  for (const auto& e : fs::directory_iterator(src / "tests/scenario/data"))
    if (e.path().extension() == ".json") files.push_back(e.path());
  std::sort(files.begin(), files.end());
  return files;
}

/// One loader case, built from its number alone (so a child can run any case): the mutated
/// scene (nullopt when the truncated text no longer parses) and its recipe.
struct LoaderSeed {
  fs::path file;
  std::string text;
  json j;
};

std::optional<json> loader_case(const std::vector<LoaderSeed>& seeds, unsigned long long seed, long long k, std::string& what) {
  const LoaderSeed& s = seeds[static_cast<std::size_t>(k) % seeds.size()];
  test::JsonMutator mut(seed * 1000003ULL + static_cast<unsigned long long>(k));
  if (mut.pick(10) == 0) {
    const std::size_t cut = mut.pick(s.text.size());
    what = "truncate at byte " + std::to_string(cut);
    json j = json::parse(s.text.substr(0, cut), nullptr, false);
    if (j.is_discarded()) return std::nullopt;
    return j;
  }
  json j = s.j;
  const std::size_t n = 1 + mut.pick(3);
  for (std::size_t q = 0; q < n; ++q) what += (q ? "; " : "") + mut.mutate_extended(j);
  return j;
}

/// Loader cases run in batches: one forked child runs cases [first, last) in a row, writing
/// "S k\n" before case k and "E k code\n" (or "B k code message\n" for a bug) after it, with
/// alarm() re-armed per case. When the child dies (signal or time limit) the case it had started
/// is the culprit; the next child resumes after it.
int run_loader(const Options& o) {
  const auto files = loader_seeds(o.source);
  std::vector<LoaderSeed> seeds;
  for (const auto& f : files) {
    std::ifstream in(f);
    std::string text((std::istreambuf_iterator<char>(in)), {});
    json j = json::parse(text, nullptr, false);
    if (j.is_discarded() || !j.is_object()) continue;
    seeds.push_back({f, std::move(text), std::move(j)});
  }
  std::cout << "loader: " << seeds.size() << " seed files\n";
  (void)registry();
  Tally t;
  fs::create_directories(o.work / "bugs");
  const auto t0 = std::chrono::steady_clock::now();
  const long long first = o.only >= 0 ? o.only : 0, last = o.only >= 0 ? o.only + 1 : o.cases;
  auto seed_name = [&](long long k) { return fs::relative(seeds[static_cast<std::size_t>(k) % seeds.size()].file, o.source).string(); };
  auto record_bug = [&](long long k, const std::string& outcome, const std::string& message) {
    std::string what;
    const auto j = loader_case(seeds, o.seed, k, what);
    const fs::path keep = o.work / "bugs" / ("loader_case_" + std::to_string(k) + ".json");
    if (j) std::ofstream(keep) << j->dump(1);
    t.bugs.push_back({{"case", k},
                      {"seed_file", seed_name(k)},
                      {"mutation", what},
                      {"outcome", outcome},
                      {"message", message.substr(0, 3000)},
                      {"input", keep.string()}});
    std::cout << "BUG case " << k << " (" << seed_name(k) << "): " << what.substr(0, 300) << " -> " << outcome << "\n" << std::flush;
  };
  long long next = first;
  bool out_of_time = false;
  auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); };
  while (next < last && !out_of_time) {
    int fd[2];
    if (::pipe(fd) != 0) throw std::runtime_error("pipe failed");
    std::fflush(nullptr);
    const pid_t pid = ::fork();
    if (pid == 0) {
      ::close(fd[0]);
      const int null_fd = ::open("/dev/null", O_RDWR);
      ::dup2(null_fd, STDIN_FILENO);
      ::dup2(null_fd, STDOUT_FILENO);
      ::dup2(null_fd, STDERR_FILENO);
      rlimit lim{static_cast<rlim_t>(kAddressSpace), static_cast<rlim_t>(kAddressSpace)};
      ::setrlimit(RLIMIT_AS, &lim);
      auto say = [&](const std::string& line) {
        if (::write(fd[1], line.data(), line.size()) < 0) ::_exit(99);
      };
      for (long long k = next; k < last; ++k) {
        std::string what;
        say("S " + std::to_string(k) + "\n");
        ::alarm(o.time_limit);
        const auto j = loader_case(seeds, o.seed, k, what);
        if (!j) {
          say("E " + std::to_string(k) + " -1\n");
          continue;
        }
        const fs::path base = seeds[static_cast<std::size_t>(k) % seeds.size()].file.parent_path();
        std::string message;
        int code = fuzz::kOk;
        try {
          (void)io::load_scenario(*j, registry(), base);
        } catch (const ConfigError&) { code = fuzz::kConfig; } catch (const SetupError&) {
          code = fuzz::kSetup;
        } catch (const std::exception& e) {
          code = fuzz::kOther;
          message = std::string(typeid(e).name()) + ": " + e.what();
        }
        ::alarm(0);
        if (code == fuzz::kOther) {
          for (char& c : message)
            if (c == '\n') c = ' ';
          say("B " + std::to_string(k) + " " + std::to_string(code) + " " + message.substr(0, 2000) + "\n");
        } else {
          say("E " + std::to_string(k) + " " + std::to_string(code) + "\n");
        }
      }
      ::_exit(0);
    }
    ::close(fd[1]);
    long long started = -1;
    std::string buffer;
    char chunk[65536];
    auto handle = [&](const std::string& line) {
      std::istringstream is(line);
      char tag;
      long long k;
      is >> tag >> k;
      if (tag == 'S') {
        started = k;
        return;
      }
      int code;
      is >> code;
      started = -1;
      next = k + 1;
      ChildResult r;
      r.exit_code = code;
      if (code == -1) {
        ++t.outcomes["unparsable after truncation (not loaded)"];
        ++t.cases;
        return;
      }
      t.add(seed_name(k), r);
      if (o.only < 0 && t.cases % 10000 == 0)
        std::cout << "  " << t.cases << " cases, " << std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() << " s\n"
                  << std::flush;
      if (tag == 'B') {
        std::string msg;
        std::getline(is, msg);
        record_bug(k, class_name(r), msg);
      }
    };
    for (;;) {
      const ssize_t n = ::read(fd[0], chunk, sizeof chunk);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) break;
      buffer.append(chunk, static_cast<std::size_t>(n));
      std::size_t pos;
      while ((pos = buffer.find('\n')) != std::string::npos) {
        handle(buffer.substr(0, pos));
        buffer.erase(0, pos + 1);
      }
      if (o.max_seconds > 0.0 && elapsed() > o.max_seconds) {
        out_of_time = true;  // the case in progress is not counted
        ::kill(pid, SIGKILL);
        break;
      }
    }
    ::close(fd[0]);
    int status = 0;
    while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {}
    if (out_of_time) break;
    if (started >= 0) {  // the child died inside case `started`
      ChildResult r;
      if (WIFSIGNALED(status)) {
        r.signal = WTERMSIG(status);
        r.kind = r.signal == SIGALRM ? ChildResult::Kind::TimedOut : ChildResult::Kind::Crashed;
      } else {
        r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -2;
      }
      t.add(seed_name(started), r);
      record_bug(started, class_name(r), "child ended inside the case");
      next = started + 1;
    } else if (!(WIFEXITED(status) && WEXITSTATUS(status) == 0) && next < last) {
      throw std::runtime_error("loader batch child ended outside a case");
    }
  }
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  write_report(o, t, secs, {{"seed_files", seeds.size()}, {"stopped_at_time_limit", out_of_time}});
  return t.bugs.empty() ? 0 : 1;
}

// ---------------------------------------------------------------------------------------------
// Checkpoint

/// Seed scenes of the checkpoint fuzzer: one per kind of state (tests/scenario/data).
const std::vector<std::string>& checkpoint_scenes() {
  static const std::vector<std::string> s = {"crash_pour.json",    "hot_press_small.json",  "joule_press_small.json",
                                             "torsion_small.json", "tension_small.json",    "cpc_small.json",
                                             "sweep_fall.json",    "restart_contracts.json"};
  return s;
}

int run_checkpoint(const Options& o) {
  std::vector<fuzz::CkptSeed> seeds;
  const auto t_seed = std::chrono::steady_clock::now();
  for (const auto& name : checkpoint_scenes()) {
    const fs::path dir = o.work / "seeds" / fs::path(name).stem();
    fs::remove_all(dir);
    fs::create_directories(dir);
    seeds.push_back(fuzz::make_checkpoint_seed(registry(), o.source / "tests/scenario/data", name, dir, 20 * o.time_limit));
    std::cout << "seed " << name << ": checkpoint at step " << seeds.back().step << ", " << seeds.back().model.size() << " datasets, "
              << seeds.back().bytes.size() << " bytes\n"
              << std::flush;
  }
  const double seed_secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_seed).count();
  Tally t;
  long long mutation_failed = 0;
  fs::create_directories(o.work / "bugs");
  const fs::path file = o.work / "case.h5", out = o.work / "case_out";
  const auto t0 = std::chrono::steady_clock::now();
  const long long first = o.only >= 0 ? o.only : 0, last = o.only >= 0 ? o.only + 1 : o.cases;
  for (long long k = first; k < last; ++k) {
    fuzz::CkptSeed& s = seeds[static_cast<std::size_t>(k) % seeds.size()];
    std::string what;
    try {
      what = fuzz::write_mutated_checkpoint(s, o.seed * 1000003ULL + static_cast<unsigned long long>(k), file);
    } catch (const std::exception& e) {
      ++mutation_failed;  // the mutated model could not be written (HDF5 refused it): not a case
      if (o.only >= 0) std::cout << "mutation failed: " << e.what() << "\n";
      continue;
    }
    const ChildResult r = fuzz::restart_case(s, file, out, o.time_limit);
    t.add(s.name, r);
    if (o.only >= 0) std::cout << "case " << k << " (" << s.name << "): " << what << "\n-> " << class_name(r) << "\n" << r.message << "\n";
    if (is_bug(r)) {
      const fs::path keep = o.work / "bugs" / ("checkpoint_case_" + std::to_string(k) + ".h5");
      fs::copy_file(file, keep, fs::copy_options::overwrite_existing);
      t.bugs.push_back({{"case", k},
                        {"seed_scene", s.name},
                        {"mutation", what},
                        {"outcome", class_name(r)},
                        {"message", r.message.substr(0, 3000)},
                        {"input", keep.string()}});
      std::cout << "BUG case " << k << " (" << s.name << "): " << what << " -> " << class_name(r) << "\n" << std::flush;
    }
    if (o.only < 0 && (k + 1) % 1000 == 0)
      std::cout << "  " << (k + 1) << " cases, " << std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() << " s\n"
                << std::flush;
  }
  std::error_code ec;
  fs::remove_all(out, ec);
  t.outcomes["mutation not writable (not run)"] = mutation_failed;
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  json seeds_j = json::array();
  for (const auto& s : seeds)
    seeds_j.push_back({{"scene", s.name}, {"step", s.step}, {"datasets", s.model.size()}, {"bytes", s.bytes.size()}});
  write_report(o, t, secs, {{"seeds", seeds_j}, {"seed_setup_s", seed_secs}});
  return t.bugs.empty() ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  if (argc < 2) {
    std::cerr << "usage: sparkdem_fuzz loader|checkpoint --cases N [--seed S] [--work DIR] [--out FILE] [--time-limit SEC] [--only K] "
                 "[--source DIR]\n";
    return 2;
  }
  o.mode = argv[1];
  for (int k = 2; k + 1 < argc; k += 2) {
    const std::string a = argv[k], v = argv[k + 1];
    if (a == "--cases")
      o.cases = std::stoll(v);
    else if (a == "--seed")
      o.seed = std::stoull(v);
    else if (a == "--work")
      o.work = v;
    else if (a == "--out")
      o.out = v;
    else if (a == "--time-limit")
      o.time_limit = static_cast<unsigned>(std::stoul(v));
    else if (a == "--only")
      o.only = std::stoll(v);
    else if (a == "--max-seconds")
      o.max_seconds = std::stod(v);
    else if (a == "--source")
      o.source = v;
    else {
      std::cerr << "unknown option " << a << "\n";
      return 2;
    }
  }
  if (o.work.empty()) o.work = fs::temp_directory_path() / ("sparkdem_fuzz_" + o.mode);
  fs::create_directories(o.work);
  omp_set_num_threads(1);
  if (o.mode == "loader") return run_loader(o);
  if (o.mode == "checkpoint") return run_checkpoint(o);
  std::cerr << "unknown mode " << o.mode << "\n";
  return 2;
}
