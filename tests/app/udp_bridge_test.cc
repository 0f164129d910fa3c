// The UDP bridge end to end, with real processes and sockets: a session
// over loopback against `device serve-sim` logs what the built-in sim
// logs, also while a forger on the same machine answers every POLL with a
// spoofed STATE and spoofs COMMANDs (authenticated bridge: none of it
// counts, all of it is counted); a wrong key or an unauthenticated bridge
// beyond loopback starts nothing; a bridge killed mid-trial ends that trial
// as device_timeout (also on the wall clock with a timeout longer than the
// loop's watchdog), re-queued, its samples and counters kept, and every
// force commanded after the timeout is zero; on the wall clock the POLLs
// carry the stored t_s; serve-sim refuses a port in use and survives
// malformed datagrams.
#include <arpa/inet.h>
#include <ifaddrs.h>
#include <net/if.h>
#include <netinet/in.h>
#include <netinet/ip.h>
#include <netinet/udp.h>
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
#include <mutex>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "app/cli_process.h"
#include "core/common/secret_file.h"
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
  int start_server(std::unique_ptr<ChildProcess>& server, const std::vector<std::string>& extra = {},
                    const std::string& host = "127.0.0.1") {
    std::vector<std::string> argv{kBinary, "device", "serve-sim", "--port", "0", "--host", host};
    argv.insert(argv.end(), extra.begin(), extra.end());
    server = std::make_unique<ChildProcess>(argv, (dir_ / ("serve_sim" + std::to_string(++servers_) + ".log")).string());
    const std::string marker = "serving the simulated workstation on udp:" + host + ":";
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

  // A new bridge key file (mode 600), as `hapticlab device keygen` makes it.
  std::string new_key_file(const std::string& name) {
    const std::string path = (dir_ / name).string();
    const auto [code, out] = run_cli(kBinary, "device keygen --out " + path);
    EXPECT_EQ(code, 0) << out;
    return path;
  }

  fs::path dir_;
  int servers_ = 0;
};

// Trial 1 of both studies, sample for sample: equal bit for bit, times
// included, and ended the same way.
void expect_same_samples(const std::string& udp_db, const std::string& sim_db,
                         db::TrialStatus status = db::TrialStatus::kComplete) {
  db::StudyDb u(udp_db), s(sim_db);
  ASSERT_EQ(u.trials().front().status, status);
  ASSERT_EQ(s.trials().front().status, status);
  EXPECT_EQ(u.trials().front().abort_reason, s.trials().front().abort_reason);
  for (int instrument = 0; instrument < 2; ++instrument) {
    const std::vector<db::StoredSample> a = u.samples(1, instrument), b = s.samples(1, instrument);
    ASSERT_EQ(a.size(), b.size());
    ASSERT_GT(a.size(), 1000u);
    for (std::size_t k = 0; k < a.size(); ++k) {
      ASSERT_EQ(std::memcmp(&a[k].value, &b[k].value, sizeof a[k].value), 0)
          << "instrument " << instrument << " update " << k;
      ASSERT_EQ(a[k].t_s, b[k].t_s);
    }
  }
}

std::map<std::string, std::uint64_t> counters_of(const std::string& db_path, std::int64_t trial_id) {
  db::StudyDb db(db_path);
  std::map<std::string, std::uint64_t> out;
  for (const auto& [name, value] : db.device_counters(trial_id)) out[name] = value;
  return out;
}

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

  // Bit for bit: the simulated workstation behind the bridge runs on the
  // times the packets carry, so it computes exactly what the built-in one does.
  expect_same_samples(udp_db, sim_db);
  db::StudyDb u(udp_db), s(sim_db);
  // The bridge's counts are stored with the trial; the sim has none.
  const auto counters = u.device_counters(1);
  ASSERT_FALSE(counters.empty());
  EXPECT_TRUE(s.device_counters(1).empty());
  for (const auto& [name, value] : counters) {
    if (name == "timeouts" || name == "stale" || name == "out_of_order" || name == "malformed" ||
        name == "rejected_mac" || name == "wrong_nonce" || name == "wrong_source" || name == "send_failed" ||
        name == "authenticated") {
      EXPECT_EQ(value, 0u) << name;
    }
    if (name == "packets_received") {
      EXPECT_GT(value, u.samples(1, 0).size()) << name;  // a STATE per update, and acks
    }
  }
}

// Between the session and serve-sim, a relay that forwards both ways,
// SIGKILLs serve-sim when the kill_at-th POLL comes by and from then on
// answers nothing but keeps listening, recording the COMMANDs and the time
// each POLL carried.
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

  std::vector<double> poll_times_s() {
    std::lock_guard<std::mutex> lock(mutex_);
    return poll_times_s_;
  }

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
          if (h.type == udp::Type::kPoll) {
            {
              std::lock_guard<std::mutex> lock(mutex_);
              poll_times_s_.push_back(h.time_s);
            }
            if (++polls == kill_at_) {
              ::kill(server_pid_, SIGKILL);
              silent = true;
            }
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
  std::mutex mutex_;
  std::vector<double> poll_times_s_;
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

// The attack, for real: a process with CAP_NET_RAW on the same
// machine sniffs the bridge on loopback and answers every POLL at once
// with a STATE 1 mm off the driver's last one, from the driver's address
// and port (IP_HDRINCL), echoing the POLL's sequence and both session
// nonces (they travel in the clear); and it sends a COMMAND of 5 N from
// the host's address and port after every POLL. It has no key: its MACs
// are made with one of its own.
class Forger {
 public:
  // Whether this process may open raw sockets (root, or CAP_NET_RAW).
  static bool permitted() {
    const int fd = ::socket(AF_INET, SOCK_RAW, IPPROTO_UDP);
    if (fd < 0) return false;
    ::close(fd);
    return true;
  }

  explicit Forger(int driver_port) : driver_port_(driver_port) {
    sniff_fd_ = ::socket(AF_INET, SOCK_RAW, IPPROTO_UDP);
    send_fd_ = ::socket(AF_INET, SOCK_RAW, IPPROTO_RAW);  // IPPROTO_RAW: we write the IP header
    if (sniff_fd_ < 0 || send_fd_ < 0) throw std::runtime_error("raw socket: " + std::string(std::strerror(errno)));
    const int buffer_bytes = 8 << 20;
    ::setsockopt(sniff_fd_, SOL_SOCKET, SO_RCVBUF, &buffer_bytes, sizeof buffer_bytes);
    const std::string own_key = "a key of the forger's own, not the bridge's";
    forger_key_ = udp::Key(std::as_bytes(std::span(own_key.data(), own_key.size())));
    thread_ = std::thread([this] { run(); });
  }
  ~Forger() {
    stop_ = true;
    thread_.join();
    ::close(sniff_fd_);
    ::close(send_fd_);
  }

  std::atomic<int> forged_states{0}, forged_commands{0};

 private:
  static constexpr std::uint16_t kForgedIpId = 0x4242;  // marks our own packets, which the sniffer sees too

  void run() {
    std::array<std::byte, 4096> packet;
    std::uint32_t device_sequence = 0;
    udp::State last_state;
    while (!stop_) {
      pollfd p{sniff_fd_, POLLIN, 0};
      if (::poll(&p, 1, 10) <= 0) continue;
      const ssize_t n = ::recv(sniff_fd_, packet.data(), packet.size(), 0);
      if (n < static_cast<ssize_t>(sizeof(iphdr) + sizeof(udphdr))) continue;
      iphdr ip;
      std::memcpy(&ip, packet.data(), sizeof ip);
      if (ntohs(ip.id) == kForgedIpId) continue;
      const std::size_t ip_bytes = ip.ihl * 4u;
      udphdr udp_header;
      std::memcpy(&udp_header, packet.data() + ip_bytes, sizeof udp_header);
      const std::byte* data = packet.data() + ip_bytes + sizeof udp_header;
      const std::size_t size = static_cast<std::size_t>(n) - ip_bytes - sizeof udp_header;
      const int from_port = ntohs(udp_header.source), to_port = ntohs(udp_header.dest);
      if (size < udp::kHeaderBytes + udp::kMacBytes) continue;
      // Read in the clear, as any sniffer can; nothing here is verified.
      udp::Header h;
      std::uint16_t type = 0;
      std::memcpy(&type, data + 6, 2);
      h.type = static_cast<udp::Type>(type);
      std::memcpy(&h.sequence, data + 8, 4);
      std::memcpy(&h.host_nonce, data + 16, 8);
      std::memcpy(&h.device_nonce, data + 24, 8);
      std::memcpy(&h.time_s, data + 32, 8);
      if (from_port == driver_port_ && h.type == udp::Type::kState) {
        device_sequence = h.sequence;
        udp::decode(data, last_state);
      } else if (to_port == driver_port_ && h.type == udp::Type::kPoll) {
        std::array<std::byte, udp::kMaxDatagramBytes> b;
        udp::State forged = last_state;
        forged.echo_sequence = h.sequence;
        forged.status = DeviceStatus::kOk;
        forged.device_time_s = h.time_s;
        for (DeviceJoints& instrument : forged.position) instrument[kJointInsertion] += 0.001;
        const udp::Header state_header{udp::Type::kState, ++device_sequence, h.time_s, h.host_nonce, h.device_nonce};
        spoof(driver_port_, from_port, b.data(), udp::encode(state_header, forged, forger_key_, b.data()));
        ++forged_states;
        udp::Command push;
        push.force[0][kJointInsertion] = 5.0;
        push.force[1][kJointInsertion] = 5.0;
        const udp::Header command_header{udp::Type::kCommand, h.sequence + 1, h.time_s, h.host_nonce, h.device_nonce};
        spoof(from_port, driver_port_, b.data(), udp::encode(command_header, push, forger_key_, b.data()));
        ++forged_commands;
      }
    }
  }

  // Sends `payload` as a UDP datagram 127.0.0.1:from_port -> 127.0.0.1:to_port.
  void spoof(int from_port, int to_port, const std::byte* payload, std::size_t size) {
    std::array<std::byte, 2048> out{};
    iphdr ip{};
    ip.version = 4;
    ip.ihl = 5;
    ip.ttl = 64;
    ip.protocol = IPPROTO_UDP;
    ip.id = htons(kForgedIpId);
    ip.tot_len = htons(static_cast<std::uint16_t>(sizeof ip + sizeof(udphdr) + size));
    ip.saddr = htonl(INADDR_LOOPBACK);
    ip.daddr = htonl(INADDR_LOOPBACK);  // the kernel fills in the IP checksum
    udphdr u{};
    u.source = htons(static_cast<std::uint16_t>(from_port));
    u.dest = htons(static_cast<std::uint16_t>(to_port));
    u.len = htons(static_cast<std::uint16_t>(sizeof u + size));
    u.check = 0;  // none: allowed for UDP over IPv4
    std::memcpy(out.data(), &ip, sizeof ip);
    std::memcpy(out.data() + sizeof ip, &u, sizeof u);
    std::memcpy(out.data() + sizeof ip + sizeof u, payload, size);
    sockaddr_in to{};
    to.sin_family = AF_INET;
    to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ::sendto(send_fd_, out.data(), sizeof ip + sizeof u + size, 0, reinterpret_cast<sockaddr*>(&to), sizeof to);
  }

  int driver_port_;
  int sniff_fd_ = -1, send_fd_ = -1;
  udp::Key forger_key_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

TEST_F(UdpBridgeTest, ForgedStatesAndCommandsFromASpoofingProcessChangeNothingAndAreCounted) {
  if (!Forger::permitted()) GTEST_SKIP() << "this process may not open raw sockets (no CAP_NET_RAW): no forger";
  const std::string key_file = new_key_file("bridge.key");
  std::unique_ptr<ChildProcess> server;
  const int port = start_server(server, {"--key-file", key_file});
  const std::string udp_db = create_study("udp"), sim_db = create_study("sim");
  // 5 s of the trial (5000 updates) are plenty for the forger and keep
  // the test short; both trials end at that limit.
  const std::string run = " --participant S1 --training-trials 0 --max-trials 1 --max-trial-s 5";
  std::pair<int, std::string> udp_run;
  int forged_states = 0, forged_commands = 0;
  {
    Forger forger(port);
    udp_run = run_cli(kBinary, "session run --db " + udp_db + run + " --device udp:127.0.0.1:" +
                                   std::to_string(port) + " --device-option timeout_ms=1000 --device-option key_file=" +
                                   key_file);
    forged_states = forger.forged_states;
    forged_commands = forger.forged_commands;
  }
  ASSERT_EQ(udp_run.first, 0) << udp_run.second;
  const auto [sim_code, sim_out] = run_cli(kBinary, "session run --db " + sim_db + run);
  ASSERT_EQ(sim_code, 0) << sim_out;
  // The forger was there: it saw the POLLs and answered most of them.
  EXPECT_GT(forged_states, 1000);
  // Every stored sample is what serve-sim computed, and serve-sim was
  // moved by the host's COMMANDs alone: the run equals the built-in sim's.
  expect_same_samples(udp_db, sim_db, db::TrialStatus::kAborted);
  const auto counters = counters_of(udp_db, 1);
  EXPECT_EQ(counters.at("authenticated"), 1u);
  EXPECT_GT(counters.at("rejected_mac"), 0u);  // the forged STATEs, stored with the trial
  EXPECT_EQ(counters.at("timeouts"), 0u);
  server->kill(SIGTERM);
  EXPECT_EQ(server->wait(), 0);
  // serve-sim refused the forged COMMANDs (and counted them).
  const std::string out = server->output();
  const std::string marker = "malformed ignored, ";
  const auto at = out.find(marker);
  ASSERT_NE(at, std::string::npos) << out;
  EXPECT_GT(std::stoull(out.substr(at + marker.size())), 0u) << out;
  EXPECT_THAT(out, HasSubstr("rejected: bad MAC"));
  EXPECT_GT(forged_commands, 1000);
}

// A local IPv4 address that is not loopback, or "" if this machine has none.
std::string non_loopback_address() {
  ifaddrs* list = nullptr;
  if (::getifaddrs(&list) != 0) return {};
  std::string found;
  for (ifaddrs* a = list; a != nullptr && found.empty(); a = a->ifa_next) {
    if (a->ifa_addr == nullptr || a->ifa_addr->sa_family != AF_INET || (a->ifa_flags & IFF_UP) == 0) continue;
    const auto* in = reinterpret_cast<const sockaddr_in*>(a->ifa_addr);
    if ((ntohl(in->sin_addr.s_addr) >> 24) == 127) continue;
    char text[INET_ADDRSTRLEN];
    if (::inet_ntop(AF_INET, &in->sin_addr, text, sizeof text) != nullptr) found = text;
  }
  ::freeifaddrs(list);
  return found;
}

TEST_F(UdpBridgeTest, AWrongKeyOrNoKeyBeyondLoopbackStartsNothing) {
  // A wrong key: serve-sim ignores the host, whose session does not start
  // and says why, naming the key file.
  std::unique_ptr<ChildProcess> server;
  const int port = start_server(server, {"--key-file", new_key_file("driver.key")});
  const std::string wrong_key = new_key_file("host.key");
  const std::string db_path = create_study("refused");
  const std::string run = "session run --db " + db_path + " --participant S1 --training-trials 0 --max-trials 1 ";
  const auto [code, out] = run_cli(kBinary, run + "--device udp:127.0.0.1:" + std::to_string(port) +
                                                " --device-option key_file=" + wrong_key);
  EXPECT_NE(code, 0) << out;
  EXPECT_THAT(out, HasSubstr("no authenticated answer from udp:127.0.0.1:" + std::to_string(port)));
  EXPECT_THAT(out, HasSubstr("device-option key_file " + wrong_key));
  EXPECT_THAT(out, HasSubstr("authentication"));
  {
    db::StudyDb db(db_path);
    for (const db::TrialRow& t : db.trials()) EXPECT_EQ(t.status, db::TrialStatus::kPlanned);
  }

  // No key to a host beyond loopback: every command that takes --device
  // refuses before a datagram leaves (the "driver" here hears nothing).
  std::string address = non_loopback_address();
  const bool have_address = !address.empty();
  if (!have_address) address = "192.0.2.1";  // TEST-NET-1: the refusal needs no answer
  const int listener = ::socket(AF_INET, SOCK_DGRAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  ::inet_pton(AF_INET, address.c_str(), &a.sin_addr);
  const bool listening = have_address && ::bind(listener, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
  const int listener_port = listening ? port_of(listener) : 5000;
  const std::string endpoint = "udp:" + address + ":" + std::to_string(listener_port);
  for (const std::string& command :
       {run + "--device " + endpoint, "device check --seconds 0.1 --device " + endpoint,
        "console --db " + db_path + " --port 0 --device " + endpoint,
        "bench udp --seconds 0.1 --host " + address + " --port " + std::to_string(listener_port)}) {
    // (a bound: a console that took it would serve until stopped)
    const auto [refused_code, refused] = testing::run_shell("timeout 20 " + std::string(kBinary) + " " + command + " 2>&1");
    EXPECT_NE(refused_code, 0) << command << "\n" << refused;
    EXPECT_THAT(refused, HasSubstr(endpoint + ": refused: the UDP bridge to " + address +
                                   ", which is not a loopback address, has no key"))
        << command;
    EXPECT_THAT(refused, HasSubstr("--device-option key_file=bridge.key")) << command;
    EXPECT_THAT(refused, HasSubstr("--insecure")) << command;
  }
  if (listening) {
    pollfd p{listener, POLLIN, 0};
    EXPECT_EQ(::poll(&p, 1, 0), 0) << "a refused command sent a datagram";
  }
  ::close(listener);

  // The far side refuses the same: serve-sim and the example driver.
  for (const std::string& serve :
       {std::string(kBinary) + " device serve-sim --port 0 --host " + address,
        "/usr/bin/python3 " + std::string(HAPTICLAB_SOURCE_DIR) + "/examples/udp_driver/udp_driver.py --port 0 --host " +
            address}) {
    const auto [serve_code, serve_out] = testing::run_shell("timeout 20 " + serve + " 2>&1");
    EXPECT_NE(serve_code, 0) << serve;
    EXPECT_THAT(serve_out, HasSubstr("--host " + address + ": refused")) << serve;
  }
  // --insecure runs it: serve-sim on that address, no key on either side.
  if (have_address) {
    std::unique_ptr<ChildProcess> open_server;
    const int open_port = start_server(open_server, {"--insecure"}, address);
    const auto [check_code, check_out] =
        run_cli(kBinary, "device check --seconds 0.1 --rate-tolerance 0.5 --insecure --device udp:" + address + ":" +
                             std::to_string(open_port) + " --device-option timeout_ms=200");
    EXPECT_EQ(check_code, 0) << check_out;
  }
}

TEST_F(UdpBridgeTest, OnTheWallClockPollsCarryTheStoredTimeAndASilentDriverIsDeviceTimeoutNotWatchdog) {
  // 300 updates (0.3 s at 1 kHz) in, serve-sim dies; the host waits 100 ms
  // for each STATE, five times the loop's 20 ms watchdog. On a loaded CI
  // machine the lateness watchdog may end the trial before the kill (the
  // session re-queues it and goes on): then the run is made again, at most
  // three times, since the relay's count of POLLs is the first trial's.
  constexpr int kKillAt = 300;
  std::unique_ptr<ChildProcess> server;
  std::unique_ptr<Relay> relay;
  std::string db_path, endpoint, out;
  int code = 0;
  for (int attempt = 0; attempt < 3; ++attempt) {
    server.reset();
    const int server_port = start_server(server);
    relay = std::make_unique<Relay>(server_port, server->pid(), kKillAt);
    db_path = create_study("wall" + std::to_string(attempt));
    endpoint = "udp:127.0.0.1:" + std::to_string(relay->port());
    std::tie(code, out) = run_cli(kBinary, "session run --db " + db_path +
                                               " --participant S1 --training-trials 0 --max-trials 1 --clock wall "
                                               "--device " + endpoint + " --device-option timeout_ms=100");
    if (out.find("(watchdog: ") == std::string::npos) break;
  }
  EXPECT_EQ(code, 3) << out;
  db::StudyDb db(db_path);
  const db::TrialRow first = db.trials().front();
  EXPECT_EQ(first.status, db::TrialStatus::kAborted);
  EXPECT_EQ(first.abort_reason, "device_timeout: no answer from " + endpoint + " within 100 ms");
  // POLL k carries the t_s that update k is stored with, to the µs
  // between the loop reading its clock and the device reading it (here
  // about 1 µs); not the clock's time since the rig was built (5-55 ms
  // more) nor since activation (about 1 ms more).
  const std::vector<double> poll_times_s = relay->poll_times_s();
  const std::vector<db::StoredSample> samples = db.samples(first.id, 0);
  ASSERT_EQ(samples.size(), static_cast<std::size_t>(kKillAt - 1));
  ASSERT_GE(poll_times_s.size(), samples.size());
  for (std::size_t k = 0; k < samples.size(); ++k)
    ASSERT_NEAR(poll_times_s[k], samples[k].t_s, 250e-6) << "update " << k;
}

TEST_F(UdpBridgeTest, ThePythonExampleDriverSpeaksTheAuthenticatedFormatAndIgnoresForgedCommands) {
  const std::string key_file = new_key_file("bridge.key");
  ChildProcess driver({"/usr/bin/python3", std::string(HAPTICLAB_SOURCE_DIR) + "/examples/udp_driver/udp_driver.py",
                       "--port", "0", "--key-file", key_file},
                      (dir_ / "driver.log").string());
  const std::string marker = "driver on udp:127.0.0.1:";
  int port = 0;
  for (int i = 0; i < 500 && port == 0; ++i) {
    const std::string out = driver.output();
    if (const auto at = out.find(marker); at != std::string::npos && out.find('\n', at) != std::string::npos)
      port = std::stoi(out.substr(at + marker.size()));
    else
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ASSERT_NE(port, 0) << driver.output();
  const std::string device = " --device udp:127.0.0.1:" + std::to_string(port) + " --device-option timeout_ms=500";
  // The host with the key: the check runs, zero force throughout.
  // Not about the rate: a Python driver on a loaded machine may lose a third of it.
  const auto [code, out] = run_cli(kBinary, "device check --seconds 0.1 --rate-tolerance 0.5" + device +
                                                " --device-option key_file=" + key_file);
  EXPECT_EQ(code, 0) << out;
  EXPECT_THAT(out, HasSubstr("(my-device)"));
  // A host of the test's own, with the key: HELLO, ACTIVATE, one COMMAND
  // of 0.5 N. Then the same COMMAND again (a replay), and 5 N COMMANDs in
  // the session (its nonces, a newer sequence) but with another key, and
  // without one.
  {
    const std::string key_hex = [&] {
      std::ifstream in(key_file);
      std::string line;
      std::getline(in, line);
      return line;
    }();
    const std::string raw_key = hex_bytes(key_hex);
    const udp::Key key(std::as_bytes(std::span(raw_key.data(), raw_key.size())));
    const std::string other_raw = "0123456789abcdef0123456789abcdef";
    const udp::Key other(std::as_bytes(std::span(other_raw.data(), other_raw.size())));
    const int fd = udp_socket_on(0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(static_cast<std::uint16_t>(port));
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    std::array<std::byte, udp::kMaxDatagramBytes> b;
    const auto send = [&](std::size_t n) { ::sendto(fd, b.data(), n, 0, reinterpret_cast<sockaddr*>(&a), sizeof a); };
    const auto receive = [&](udp::Header& h) {
      pollfd p{fd, POLLIN, 0};
      if (::poll(&p, 1, 2000) <= 0) return false;
      const ssize_t n = ::recv(fd, b.data(), b.size(), 0);
      return n > 0 && udp::decode_header(b.data(), static_cast<std::size_t>(n), key, h) == udp::Verdict::kOk;
    };
    const std::uint64_t host_nonce = 0x5eed5eed5eed5eedull;
    send(udp::encode(udp::Header{udp::Type::kHello, 1, 0.0, host_nonce, 0}, key, b.data()));
    udp::Header reply;
    ASSERT_TRUE(receive(reply));
    const std::uint64_t device_nonce = reply.device_nonce;
    send(udp::encode(udp::Header{udp::Type::kActivate, 2, 0.0, host_nonce, device_nonce}, key, b.data()));
    ASSERT_TRUE(receive(reply));
    udp::Command push;
    push.force[0][kJointInsertion] = 0.5;
    const std::size_t n = udp::encode(udp::Header{udp::Type::kCommand, 3, 0.0, host_nonce, device_nonce}, push, key,
                                      b.data());
    send(n);
    send(n);  // replayed
    push.force[0][kJointInsertion] = 5.0;
    send(udp::encode(udp::Header{udp::Type::kCommand, 4, 0.0, host_nonce, device_nonce}, push, other, b.data()));
    send(udp::encode(udp::Header{udp::Type::kCommand, 5, 0.0, host_nonce, device_nonce}, push, udp::Key{}, b.data()));
    send(udp::encode(udp::Header{udp::Type::kCommand, 6, 0.0, host_nonce + 1, device_nonce}, push, key, b.data()));
    send(udp::encode(udp::Header{udp::Type::kDeactivate, 7, 0.0, host_nonce, device_nonce}, key, b.data()));
    ASSERT_TRUE(receive(reply));  // every datagram before the DEACTIVATE has been handled
    ::close(fd);
  }
  driver.kill(SIGTERM);
  driver.wait();
  // The 0.5 N COMMAND applied once; the replay, the forgeries and the
  // other session's refused, each by what gave it away.
  const std::string log = driver.output();
  EXPECT_THAT(log, HasSubstr("rejected_mac 2, wrong_nonce 1, old_sequence 1, commands "));
  EXPECT_THAT(log, HasSubstr("largest force applied 0.5, force held at stop 0\n"));
}

// Review of issue 33: an old HELLO replayed off the wire (its MAC stays
// valid) made the example driver start a new session and refuse the live
// host's zero COMMAND and DEACTIVATE, so 5 N stayed on the motor. A HELLO of
// another session is now refused while the live one sends COMMANDs, a new
// session starts from zero force, and a host that falls silent is zeroed
// after 50 ms.
TEST_F(UdpBridgeTest, TheExampleDriverKeepsALiveSessionFromAReplayedHelloAndZeroesASilentOne) {
  const std::string key_file = new_key_file("bridge.key");
  // A host silent for 300 ms is dead here (50 ms by default): room for a
  // loaded CI machine to deschedule either process between COMMANDs.
  ChildProcess driver({"/usr/bin/python3", std::string(HAPTICLAB_SOURCE_DIR) + "/examples/udp_driver/udp_driver.py",
                       "--port", "0", "--key-file", key_file, "--command-timeout-ms", "300"},
                      (dir_ / "driver.log").string());
  const std::string marker = "driver on udp:127.0.0.1:";
  int port = 0;
  for (int i = 0; i < 500 && port == 0; ++i) {
    const std::string out = driver.output();
    if (const auto at = out.find(marker); at != std::string::npos && out.find('\n', at) != std::string::npos)
      port = std::stoi(out.substr(at + marker.size()));
    else
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ASSERT_NE(port, 0) << driver.output();
  const std::string raw_key = hex_bytes([&] {
    std::ifstream in(key_file);
    std::string line;
    std::getline(in, line);
    return line;
  }());
  const udp::Key key(std::as_bytes(std::span(raw_key.data(), raw_key.size())));
  const int fd = udp_socket_on(0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<std::uint16_t>(port));
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  std::array<std::byte, udp::kMaxDatagramBytes> b;
  std::array<std::byte, udp::kMaxDatagramBytes> old_hello;
  const auto send_bytes = [&](const std::byte* p, std::size_t n) {
    ::sendto(fd, p, n, 0, reinterpret_cast<sockaddr*>(&a), sizeof a);
  };
  const auto send = [&](std::size_t n) { send_bytes(b.data(), n); };
  const auto receive = [&](udp::Header& h) {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, 1000) <= 0) return false;
    const ssize_t n = ::recv(fd, b.data(), b.size(), 0);
    return n > 0 && udp::decode_header(b.data(), static_cast<std::size_t>(n), key, h) == udp::Verdict::kOk;
  };
  udp::Header reply;
  // An earlier session's HELLO, as recorded off the wire.
  const std::size_t old_hello_bytes =
      udp::encode(udp::Header{udp::Type::kHello, 1, 0.0, 0x1111, 0}, key, old_hello.data());
  send_bytes(old_hello.data(), old_hello_bytes);
  ASSERT_TRUE(receive(reply));
  // The live session: HELLO, ACTIVATE, 5 N.
  const std::uint64_t host_nonce = 0x2222;
  send(udp::encode(udp::Header{udp::Type::kHello, 1, 0.0, host_nonce, 0}, key, b.data()));
  ASSERT_TRUE(receive(reply));
  const std::uint64_t device_nonce = reply.device_nonce;
  send(udp::encode(udp::Header{udp::Type::kActivate, 2, 0.0, host_nonce, device_nonce}, key, b.data()));
  ASSERT_TRUE(receive(reply));
  udp::Command push;
  push.force[0][kJointInsertion] = 5.0;
  std::uint32_t seq = 3;
  send(udp::encode(udp::Header{udp::Type::kCommand, seq++, 0.0, host_nonce, device_nonce}, push, key, b.data()));
  // The attacker replays the old HELLO amid the host's COMMANDs: no answer,
  // the session stays.
  send_bytes(old_hello.data(), old_hello_bytes);
  for (int k = 0; k < 20; ++k) {
    send(udp::encode(udp::Header{udp::Type::kCommand, seq++, 0.0, host_nonce, device_nonce}, push, key, b.data()));
    pollfd p{fd, POLLIN, 0};
    EXPECT_EQ(::poll(&p, 1, 5), 0) << "the replayed HELLO was answered";
  }
  // ... and the host's own end of the trial is taken: zero, DEACTIVATE, its ACK.
  send(udp::encode(udp::Header{udp::Type::kCommand, seq++, 0.0, host_nonce, device_nonce}, udp::Command{}, key,
                   b.data()));
  send(udp::encode(udp::Header{udp::Type::kDeactivate, seq++, 0.0, host_nonce, device_nonce}, key, b.data()));
  ASSERT_TRUE(receive(reply));
  EXPECT_EQ(reply.type, udp::Type::kAck);
  // A host that dies with 5 N on: after its timeout without a COMMAND the driver zeroes.
  const std::uint64_t second = 0x3333;
  send(udp::encode(udp::Header{udp::Type::kHello, 1, 0.0, second, 0}, key, b.data()));
  ASSERT_TRUE(receive(reply));
  const std::uint64_t second_device = reply.device_nonce;
  send(udp::encode(udp::Header{udp::Type::kActivate, 2, 0.0, second, second_device}, key, b.data()));
  ASSERT_TRUE(receive(reply));
  send(udp::encode(udp::Header{udp::Type::kCommand, 3, 0.0, second, second_device}, push, key, b.data()));
  std::this_thread::sleep_for(std::chrono::milliseconds(800));
  ::close(fd);
  driver.kill(SIGTERM);
  driver.wait();
  const std::string log = driver.output();
  EXPECT_THAT(log, HasSubstr("busy_hello 1, command_timeouts 1"));
  EXPECT_THAT(log, HasSubstr("largest force applied 5, force held at stop 0\n"));
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
