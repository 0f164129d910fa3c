// The UDP bridge end to end, with real processes and sockets: a session
// over loopback against `device serve-sim` logs what the built-in sim
// logs; a bridge killed mid-trial ends that trial as device_timeout,
// re-queued, its samples and counters kept, and every force commanded
// after the timeout is zero; serve-sim refuses a port in use and survives
// malformed datagrams.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <cstring>
#include <map>
#include <string>
#include <thread>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "app/cli_process.h"
#include "core/device/udp_device.h"
#include "core/device/udp_protocol.h"
#include "db/study_db.h"
#include "testing/child_process.h"
#include "tests/testing/test_paths.h"

namespace hapticlab {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::StartsWith;
using testing::ChildProcess;
using testing::run_cli;


int udp_socket_on(int port) {
  const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<std::uint16_t>(port));
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) throw std::runtime_error("bind failed");
  return fd;
}

int port_of(int fd) {
  sockaddr_in a{};
  socklen_t len = sizeof a;
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
  return ntohs(a.sin_port);
}

class UdpBridgeTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("hapticlab_udp_bridge_" + std::string(info->name()) + "_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string create_study(const std::string& name) {
    const std::string db = (dir_ / (name + ".db")).string();
    const auto [code, out] = run_cli(kBinary, "study create --protocol " + std::string(HAPTICLAB_SOURCE_DIR) +
                                                  "/examples/protocols/thesis_quick.json --db " + db);
    EXPECT_EQ(code, 0) << out;
    return db;
  }

  // Starts serve-sim on a free port and waits for its ready line; returns the port.
  int start_server(std::unique_ptr<ChildProcess>& server) {
    server = std::make_unique<ChildProcess>(
        std::vector<std::string>{kBinary, "device", "serve-sim", "--port", "0"}, (dir_ / "serve_sim.log").string());
    const std::string marker = "serving the simulated workstation on udp:127.0.0.1:";
    for (int i = 0; i < 500; ++i) {
      const std::string out = server->output();
      if (const auto at = out.find(marker); at != std::string::npos && out.find('\n', at) != std::string::npos)
        return std::stoi(out.substr(at + marker.size()));
      if (!server->running()) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    ADD_FAILURE() << "serve-sim did not get ready: " << server->output();
    return 0;
  }

  fs::path dir_;
};

TEST_F(UdpBridgeTest, SessionOverTheBridgeLogsWhatTheBuiltInSimLogs) {
  std::unique_ptr<ChildProcess> server;
  const int port = start_server(server);
  const std::string udp_db = create_study("udp"), sim_db = create_study("sim");
  const std::string run = " --participant S1 --training-trials 0 --max-trials 1";
  // A generous timeout: this test is about the samples, and a loaded CI
  // machine may hold serve-sim off the CPU for more than 10 ms.
  const auto [udp_code, udp_out] = run_cli(kBinary, "session run --db " + udp_db + run + " --device udp:127.0.0.1:" +
                                                        std::to_string(port) + " --device-option timeout_ms=1000");
  ASSERT_EQ(udp_code, 0) << udp_out;
  const auto [sim_code, sim_out] = run_cli(kBinary, "session run --db " + sim_db + run);
  ASSERT_EQ(sim_code, 0) << sim_out;

  db::StudyDb u(udp_db), s(sim_db);
  ASSERT_EQ(u.trials().front().status, db::TrialStatus::kComplete);
  for (int instrument = 0; instrument < 2; ++instrument) {
    const std::vector<db::StoredSample> a = u.samples(1, instrument), b = s.samples(1, instrument);
    ASSERT_EQ(a.size(), b.size());
    ASSERT_GT(a.size(), 1000u);
    // Bit for bit: the simulated workstation behind the bridge runs on the
    // times the packets carry, so it computes exactly what the built-in one does.
    for (std::size_t k = 0; k < a.size(); ++k) {
      ASSERT_EQ(std::memcmp(&a[k].value, &b[k].value, sizeof a[k].value), 0) << "instrument " << instrument << " update " << k;
      ASSERT_EQ(a[k].t_s, b[k].t_s);
    }
  }
  // The bridge's counts are stored with the trial; the sim has none.
  const auto counters = u.device_counters(1);
  ASSERT_FALSE(counters.empty());
  EXPECT_TRUE(s.device_counters(1).empty());
  for (const auto& [name, value] : counters) {
    if (name == "timeouts" || name == "stale" || name == "out_of_order" || name == "malformed") {
      EXPECT_EQ(value, 0u) << name;
    }
    if (name == "packets_received") {
      EXPECT_GT(value, u.samples(1, 0).size()) << name;  // a STATE per update, and acks
    }
  }
}

// Between the session and serve-sim, a relay that forwards both ways,
// SIGKILLs serve-sim when the kill_at-th POLL comes by and from then on
// answers nothing but keeps listening, recording the COMMANDs.
class Relay {
 public:
  Relay(int server_port, pid_t server_pid, int kill_at) : server_pid_(server_pid), kill_at_(kill_at) {
    host_fd_ = udp_socket_on(0);
    up_fd_ = ::socket(AF_INET, SOCK_DGRAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(static_cast<std::uint16_t>(server_port));
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ::connect(up_fd_, reinterpret_cast<sockaddr*>(&a), sizeof a);
    thread_ = std::thread([this] { run(); });
  }
  ~Relay() {
    stop_ = true;
    thread_.join();
    ::close(host_fd_);
    ::close(up_fd_);
  }
  int port() const { return port_of(host_fd_); }

  std::atomic<int> polls{0};
  std::atomic<int> nonzero_commands_before{0};
  std::atomic<int> commands_after{0};
  std::atomic<int> nonzero_commands_after{0};

 private:
  void run() {
    std::array<std::byte, 2048> buf;
    sockaddr_in host{};
    socklen_t host_len = sizeof host;
    bool silent = false;
    while (!stop_) {
      pollfd p[2] = {{host_fd_, POLLIN, 0}, {up_fd_, POLLIN, 0}};
      if (::poll(p, 2, 10) <= 0) continue;
      if (p[0].revents & POLLIN) {
        host_len = sizeof host;
        const ssize_t n = ::recvfrom(host_fd_, buf.data(), buf.size(), 0, reinterpret_cast<sockaddr*>(&host), &host_len);
        udp::Header h;
        if (n > 0 && udp::decode_header(buf.data(), static_cast<std::size_t>(n), udp::Key{}, h) == udp::Verdict::kOk) {
          if (h.type == udp::Type::kPoll && ++polls == kill_at_) {
            ::kill(server_pid_, SIGKILL);
            silent = true;
          }
          if (h.type == udp::Type::kCommand) {
            udp::Command c;
            udp::decode(buf.data(), c);
            bool nonzero = false;
            for (const auto& j : c.force)
              for (double f : j) nonzero = nonzero || f != 0.0;
            if (silent) {
              ++commands_after;
              if (nonzero) ++nonzero_commands_after;
            } else if (nonzero) {
              ++nonzero_commands_before;
            }
          }
        }
        if (!silent && n > 0) ::send(up_fd_, buf.data(), static_cast<std::size_t>(n), 0);
      }
      if (p[1].revents & (POLLIN | POLLERR)) {
        const ssize_t n = ::recv(up_fd_, buf.data(), buf.size(), 0);
        if (!silent && n > 0)
          ::sendto(host_fd_, buf.data(), static_cast<std::size_t>(n), 0, reinterpret_cast<sockaddr*>(&host), host_len);
      }
    }
  }

  pid_t server_pid_;
  int kill_at_;
  int host_fd_ = -1, up_fd_ = -1;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

TEST_F(UdpBridgeTest, BridgeKilledMidTrialAbortsItAsDeviceTimeoutWithZeroForceAfter) {
  std::unique_ptr<ChildProcess> server;
  const int server_port = start_server(server);
  // The 2000th POLL is 2 s into the first trial (1 kHz, virtual clock);
  // the quick protocol's first trial runs for over 20 s.
  constexpr int kKillAt = 2000;
  Relay relay(server_port, server->pid(), kKillAt);
  const std::string db_path = create_study("killed");
  const std::string endpoint = "udp:127.0.0.1:" + std::to_string(relay.port());
  // 200 ms rather than the default 10: a loaded CI machine can hold
  // serve-sim off the CPU for tens of ms, which would end the trial early.
  const auto [code, out] = run_cli(kBinary, "session run --db " + db_path +
                                                " --participant S1 --training-trials 0 --max-trials 2 --device " +
                                                endpoint + " --device-option timeout_ms=200");
  EXPECT_EQ(code, 3) << out;  // the device fault exit code
  EXPECT_THAT(out, HasSubstr("device_timeout: no answer from " + endpoint + " within 200 ms"));
  EXPECT_EQ(server->wait(), -SIGKILL);

  // The loop ended on the timeout and commanded zero from then on: the
  // loop's closing write and deactivate()'s. Before, the Inertia setting
  // pushed back on the moving hand.
  EXPECT_GT(relay.nonzero_commands_before.load(), 100);
  EXPECT_GE(relay.commands_after.load(), 1);
  EXPECT_EQ(relay.nonzero_commands_after.load(), 0);

  db::StudyDb db(db_path);
  const std::vector<db::TrialRow> trials = db.trials();
  const db::TrialRow& first = trials.front();
  ASSERT_EQ(first.id, 1);
  EXPECT_EQ(first.status, db::TrialStatus::kAborted);
  EXPECT_THAT(first.abort_reason, StartsWith("device_timeout"));
  // Re-queued: a planned copy at its place in the schedule.
  int copies = 0;
  for (const db::TrialRow& t : trials)
    if (t.id != first.id && t.participant_code == first.participant_code && t.position == first.position && t.status == db::TrialStatus::kPlanned) ++copies;
  EXPECT_EQ(copies, 1);
  // Its samples up to the kill are kept: one update per answered POLL
  // before the kill_at-th, which found no one.
  EXPECT_EQ(db.samples(1, 0).size(), static_cast<std::size_t>(kKillAt - 1));
  std::map<std::string, std::uint64_t> counters;
  for (const auto& [name, value] : db.device_counters(1)) counters[name] = value;
  EXPECT_GE(counters["timeouts"], 1u);  // the read (deactivate()'s unanswered ACK may add one)
  EXPECT_GE(counters["packets_received"], static_cast<std::uint64_t>(kKillAt - 1));

  // The export carries them with the trial.
  const auto [export_code, export_out] =
      run_cli(kBinary, "export --db " + db_path + " --format csv --out " + (dir_ / "export").string());
  ASSERT_EQ(export_code, 0) << export_out;
  std::ifstream index(dir_ / "export" / "trials.csv");
  std::string header, row;
  std::getline(index, header);
  std::getline(index, row);
  EXPECT_THAT(header, ::testing::EndsWith(",device_counters"));
  EXPECT_THAT(row, HasSubstr("timeouts=" + std::to_string(counters["timeouts"])));
}

TEST_F(UdpBridgeTest, ServeSimOnAPortInUseIsAClearError) {
  const int fd = udp_socket_on(0);
  const int port = port_of(fd);
  const auto [code, out] = run_cli(kBinary, "device serve-sim --port " + std::to_string(port));
  ::close(fd);
  EXPECT_NE(code, 0);
  EXPECT_THAT(out, HasSubstr("port " + std::to_string(port) + " is in use"));
}

TEST_F(UdpBridgeTest, ServeSimIgnoresMalformedDatagramsAndKeepsServing) {
  std::unique_ptr<ChildProcess> server;
  const int port = start_server(server);
  {
    const int fd = udp_socket_on(0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(static_cast<std::uint16_t>(port));
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    const char junk[] = "not a HapticLab datagram";
    ::sendto(fd, junk, sizeof junk, 0, reinterpret_cast<sockaddr*>(&a), sizeof a);
    std::array<std::byte, udp::kMaxDatagramBytes> b;
    const std::size_t n = udp::encode(udp::Header{udp::Type::kPoll, 1, 0.0}, udp::Key{}, b.data());
    ::sendto(fd, b.data(), n - 1, 0, reinterpret_cast<sockaddr*>(&a), sizeof a);  // truncated
    ::close(fd);
  }
  UdpDeviceOptions o;
  o.port = port;
  UdpDevice device(o);  // throws if serve-sim stopped answering
  EXPECT_TRUE(device.simulated());
  EXPECT_TRUE(server->running());
  server->kill(SIGTERM);
  EXPECT_EQ(server->wait(), 0);
  EXPECT_THAT(server->output(), HasSubstr("2 malformed ignored"));
}

}  // namespace
}  // namespace hapticlab
