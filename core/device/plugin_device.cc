#include "core/device/plugin_device.h"

#include <dlfcn.h>
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <system_error>
#include <vector>

#include "core/common/signal_name.h"
#include "core/common/clock.h"

namespace hapticlab {

// The ABI's status codes are DeviceStatus, one to one.
static_assert(HL_DEVICE_OK == static_cast<int>(DeviceStatus::kOk));
static_assert(HL_DEVICE_NOT_CONFIGURED == static_cast<int>(DeviceStatus::kNotConfigured));
static_assert(HL_DEVICE_NOT_ACTIVE == static_cast<int>(DeviceStatus::kNotActive));
static_assert(HL_DEVICE_INVALID_CONFIG == static_cast<int>(DeviceStatus::kInvalidConfig));
static_assert(HL_DEVICE_READ_FAILED == static_cast<int>(DeviceStatus::kReadFailed));
static_assert(HL_DEVICE_NON_FINITE_READING == static_cast<int>(DeviceStatus::kNonFiniteReading));
static_assert(HL_DEVICE_OUT_OF_RANGE == static_cast<int>(DeviceStatus::kOutOfRange));
static_assert(HL_DEVICE_WRITE_FAILED == static_cast<int>(DeviceStatus::kWriteFailed));
static_assert(HL_DEVICE_END_OF_DATA == static_cast<int>(DeviceStatus::kEndOfData));
static_assert(HL_DEVICE_NOT_CALIBRATED == static_cast<int>(DeviceStatus::kNotCalibrated));
static_assert(HL_DEVICE_TIMEOUT == static_cast<int>(DeviceStatus::kTimeout));
static_assert(HL_DEVICE_CRASHED == static_cast<int>(DeviceStatus::kDeviceCrashed));
static_assert(HL_DEVICE_HUNG == static_cast<int>(DeviceStatus::kDeviceHung));
static_assert(kNumDeviceStatuses == HL_DEVICE_HUNG + 1, "a DeviceStatus without an HL_DEVICE_ code");
static_assert(HL_DEVICE_NUM_JOINTS == kNumDeviceJoints && HL_DEVICE_NUM_INSTRUMENTS == 2);

namespace {

constexpr const char* kJointNames[kNumDeviceJoints] = {"insertion", "pitch", "yaw", "twist", "grip"};
constexpr const char* kInstrumentNames[2] = {"left", "right"};

// The calls whose status is checked, by PluginDevice::UnknownStatus::op
// (0: none), with the status an unknown code of each counts as.
struct CheckedCall {
  const char* name;
  DeviceStatus taken_as;
};
constexpr CheckedCall kCheckedCalls[] = {{"", DeviceStatus::kOk},
                                         {"configure", DeviceStatus::kInvalidConfig},
                                         {"ratings", DeviceStatus::kInvalidConfig},
                                         {"activate", DeviceStatus::kInvalidConfig},
                                         {"read", DeviceStatus::kReadFailed},
                                         {"write", DeviceStatus::kWriteFailed},
                                         {"deactivate", DeviceStatus::kWriteFailed}};
enum CallOp : std::int32_t { kOpConfigure = 1, kOpRatings, kOpActivate, kOpRead, kOpWrite, kOpDeactivate };

double clock_now_s(void* context) { return static_cast<const Clock*>(context)->now_s(); }

std::string number(double value) {
  std::ostringstream s;
  s << value;
  return s.str();
}

// The file at `path` as a plugin names it, refused when it is none.
void check_plugin_file(const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::is_directory(path, ec))
    throw std::runtime_error("plugin " + path + ": is a directory; expected the plugin's shared library file (.so)");
  if (!fs::is_regular_file(path, ec)) throw std::runtime_error("plugin " + path + ": no such file");
}

// dlopen of the plugin's file; throws with the loader's reason.
void* open_plugin_library(const std::string& path, int flags) {
  std::error_code ec;
  // dlopen searches the library path for a name without a slash; the
  // operator means the file.
  const std::string file = std::filesystem::absolute(path, ec).string();
  void* library = ::dlopen(file.c_str(), flags);
  if (library == nullptr) {
    const char* why = ::dlerror();
    throw std::runtime_error("plugin " + path + " could not be loaded: " + (why != nullptr ? why : "unknown reason"));
  }
  return library;
}

// The plugin's entry point in `library`; throws when it has none.
void* plugin_entry(void* library, const std::string& path) {
  void* symbol = ::dlsym(library, HL_DEVICE_PLUGIN_ENTRY);
  if (symbol == nullptr)
    throw std::runtime_error("plugin " + path + " does not export " HL_DEVICE_PLUGIN_ENTRY
                             "(), so it is not a HapticLab device plugin (see hapticlab/device_plugin.h)");
  return symbol;
}

}  // namespace

void check_plugin_library(const std::string& path) {
  check_plugin_file(path);
  // Its first bytes only, never loaded: loading would run the plugin's
  // static constructors in this process, unsupervised (a vendor SDK that
  // opens USB or hangs at load would take the console down, which
  // plugin-isolated: exists to prevent), and unloading them again is what
  // PluginDevice's RTLD_NODELETE avoids.
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw std::runtime_error("plugin " + path + ": cannot be read: " + std::strerror(errno));
  unsigned char magic[4] = {};
  const ssize_t n = ::read(fd, magic, sizeof magic);
  ::close(fd);
  if (n != static_cast<ssize_t>(sizeof magic) || magic[0] != 0x7f || magic[1] != 'E' || magic[2] != 'L' ||
      magic[3] != 'F')
    throw std::runtime_error("plugin " + path + ": is not a shared library (no ELF header); name the plugin's .so file");
}

PluginDevice::PluginDevice(const std::string& path, const std::map<std::string, std::string>& options,
                           StageHook stage, void* stage_context)
    : path_(path) {
  const auto at = [&](const char* name) {
    if (stage != nullptr) stage(stage_context, name);
  };
  check_plugin_file(path);

  at("load");
  // RTLD_NODELETE: a plugin's static destructors and thread_local cleanups
  // may run after dlclose otherwise; each trial opens the device again.
  library_ = open_plugin_library(path, RTLD_NOW | RTLD_LOCAL | RTLD_NODELETE);
  try {
    at("hl_device_plugin_entry");
    using Entry = const hl_device_plugin* (*)();
    void* symbol = plugin_entry(library_, path);
    table_ = reinterpret_cast<Entry>(symbol)();
    if (table_ == nullptr)
      throw std::runtime_error("plugin " + path + ": " HL_DEVICE_PLUGIN_ENTRY "() returned no function table");
    // The version first: in another version even struct_size may mean
    // something else.
    if (table_->abi_version != HL_DEVICE_PLUGIN_ABI_VERSION)
      throw std::runtime_error("plugin " + path + " was built for device ABI " + std::to_string(table_->abi_version) +
                               ", this HapticLab supports " + std::to_string(HL_DEVICE_PLUGIN_ABI_VERSION) +
                               "; rebuild it against hapticlab/device_plugin.h of this version");
    if (table_->struct_size < sizeof(hl_device_plugin))
      throw std::runtime_error("plugin " + path + " declares a function table of " +
                               std::to_string(table_->struct_size) + " bytes; device ABI " +
                               std::to_string(HL_DEVICE_PLUGIN_ABI_VERSION) + " has " +
                               std::to_string(sizeof(hl_device_plugin)) +
                               "; rebuild it against hapticlab/device_plugin.h of this version");
    const std::pair<const char*, bool> required[] = {
        {"create", table_->create != nullptr},         {"configure", table_->configure != nullptr},
        {"ratings", table_->ratings != nullptr},       {"activate", table_->activate != nullptr},
        {"read", table_->read != nullptr},             {"write", table_->write != nullptr},
        {"deactivate", table_->deactivate != nullptr}, {"halt", table_->halt != nullptr},
        {"name", table_->name != nullptr},             {"destroy", table_->destroy != nullptr}};
    for (const auto& [field, present] : required)
      if (!present)
        throw std::runtime_error("plugin " + path + " leaves the required function '" + field +
                                 "' NULL in its function table");
    const hl_device_sim_extension* sim = table_->sim;
    if (sim != nullptr && (sim->set_start_pose == nullptr || sim->set_hand == nullptr ||
                           sim->hand_force == nullptr || sim->motor_force == nullptr))
      throw std::runtime_error("plugin " + path + " has a simulation extension with a NULL function");

    at("create");
    std::vector<const char*> keys, values;
    for (const auto& [key, value] : options) {
      keys.push_back(key.c_str());
      values.push_back(value.c_str());
    }
    char error[512] = {};
    device_ = table_->create(keys.data(), values.data(), keys.size(), error, sizeof error);
    if (device_ == nullptr) {
      error[sizeof error - 1] = '\0';
      throw std::invalid_argument("plugin " + path + " refused its options: " +
                                  (error[0] != '\0' ? std::string(error) : std::string("(it gave no reason)")));
    }
    keep_name(table_->name(device_));
  } catch (...) {
    ::dlclose(library_);
    throw;
  }
}

PluginDevice::~PluginDevice() {
  if (active_) table_->deactivate(device_);
  table_->destroy(device_);
  ::dlclose(library_);
}

DeviceStatus PluginDevice::configure(const DeviceConfig& config) {
  configure_error_.clear();
  if (active_) return DeviceStatus::kInvalidConfig;
  const DeviceStatus status =
      checked(table_->configure(device_, config.nominal_rate_Hz, config.seed), kOpConfigure);
  if (status != DeviceStatus::kOk) {
    configure_error_ = "plugin " + path_ + " refused its configuration (" + to_string(status) + ") at rate_Hz " +
                       number(config.nominal_rate_Hz);
    return status;
  }
  hl_device_ratings raw{};
  const DeviceStatus rated = checked(table_->ratings(device_, &raw), kOpRatings);
  if (rated != DeviceStatus::kOk) {
    configure_error_ = "plugin " + path_ + " gave no ratings (" + std::string(to_string(rated)) + ")";
    return DeviceStatus::kInvalidConfig;
  }
  DeviceRatings ratings;
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < kNumDeviceJoints; ++j) {
      const hl_device_joint_rating& r = raw.joint[i][j];
      ratings.joint[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)] = {
          r.min_position, r.max_position, r.continuous_force, r.peak_force, r.max_velocity};
    }
  configure_error_ = check_ratings("plugin " + path_, ratings);
  if (!configure_error_.empty()) return DeviceStatus::kInvalidConfig;
  ratings_ = ratings;
  return DeviceStatus::kOk;
}

DeviceStatus PluginDevice::activate(const Clock& clock) {
  if (active_) return DeviceStatus::kOk;
  clock_ = {const_cast<Clock*>(&clock), &clock_now_s};
  // A trial's failure is its own, not an earlier trial's (each trial
  // activates the device).
  unknown_op_.store(0, std::memory_order_relaxed);
  const DeviceStatus status = checked(table_->activate(device_, &clock_), kOpActivate);
  active_ = status == DeviceStatus::kOk;
  return status;
}

DeviceStatus PluginDevice::read(DeviceReading& reading) noexcept {
  // NaN in every field first: a plugin that answers OK without filling a
  // position (the ABI says fill every one) gives a non-finite reading, a
  // fault, instead of whatever the stack held (often the last reading:
  // a tool that seems still while force is commanded).
  hl_device_reading raw;
  for (auto& instrument : raw.position)
    for (double& x : instrument) x = std::numeric_limits<double>::quiet_NaN();
  raw.device_time_s = std::numeric_limits<double>::quiet_NaN();
  const DeviceStatus status = checked(table_->read(device_, &raw), kOpRead);
  if (status != DeviceStatus::kOk) return status;
  bool finite = true;
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < kNumDeviceJoints; ++j) {
      const double x = raw.position[i][j];
      finite = finite && std::isfinite(x);
      reading.position[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)] = x;
    }
  reading.device_time_s = raw.device_time_s;
  return finite ? DeviceStatus::kOk : DeviceStatus::kNonFiniteReading;
}

DeviceStatus PluginDevice::write(const DeviceCommand& command) noexcept {
  hl_device_command raw;
  bool finite = true;
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < kNumDeviceJoints; ++j) {
      const auto ui = static_cast<std::size_t>(i), uj = static_cast<std::size_t>(j);
      const double f = command.force[ui][uj];
      const double peak = ratings_.joint[ui][uj].peak_force;
      finite = finite && std::isfinite(f);
      // The plugin clips too; this holds even if it does not.
      raw.force[i][j] = std::clamp(f, -peak, peak);
    }
  if (!finite) {
    // A non-finite value never reaches a motor: zero force instead.
    raw = hl_device_command{};
    table_->write(device_, &raw);
    return DeviceStatus::kWriteFailed;
  }
  return checked(table_->write(device_, &raw), kOpWrite);
}

DeviceStatus PluginDevice::deactivate() noexcept {
  active_ = false;
  return checked(table_->deactivate(device_), kOpDeactivate);
}

void PluginDevice::halt() noexcept { table_->halt(device_); }

// HL_DEVICE_CRASHED and HL_DEVICE_HUNG are HapticLab's word about a plugin's
// process, not the plugin's own: from a plugin they count as unknown.
DeviceStatus PluginDevice::checked(hl_device_status status, std::int32_t op) noexcept {
  const bool known = status >= 0 && status <= HL_DEVICE_TIMEOUT;
  if (known && status == HL_DEVICE_OK) return DeviceStatus::kOk;
  // Only the first failure is kept: after it the loop writes zero force and
  // deactivates, and what those calls answer is not why the trial ended.
  if (unknown_op_.load(std::memory_order_relaxed) == 0) {
    unknown_code_.store(static_cast<std::int32_t>(status), std::memory_order_relaxed);
    unknown_op_.store(known ? -1 : op, std::memory_order_relaxed);
  }
  return known ? static_cast<DeviceStatus>(status) : kCheckedCalls[op].taken_as;
}

std::string PluginDevice::status_detail() const { return describe_unknown_status(unknown_status()); }

std::string describe_unknown_status(PluginDevice::UnknownStatus unknown) {
  if (unknown.op <= 0 || unknown.op >= static_cast<std::int32_t>(std::size(kCheckedCalls))) return "";
  const CheckedCall& call = kCheckedCalls[unknown.op];
  return std::string("the plugin's ") + call.name + " returned " + std::to_string(unknown.code) +
         ", which is no hl_device_status (taken as " + to_string(call.taken_as) + ")";
}

const char* PluginDevice::name() const noexcept { return name_.data(); }

// The plugin's name, read once: at most kNameChars bytes (a name without
// its NUL is not read further), each byte outside printable ASCII shown as
// '?' (a newline or an escape sequence in it would forge lines on the
// operator's terminal and in logs); "plugin" for none.
void PluginDevice::keep_name(const char* name) noexcept {
  name_.fill('\0');
  const std::size_t n = name != nullptr ? ::strnlen(name, kNameChars) : 0;
  for (std::size_t i = 0; i < n; ++i) {
    const auto c = static_cast<unsigned char>(name[i]);
    name_[i] = c >= 0x20 && c < 0x7f ? static_cast<char>(c) : '?';
  }
  if (n == 0) std::memcpy(name_.data(), "plugin", 7);
}

bool PluginDevice::set_start_pose(int instrument, const DeviceJoints& position) noexcept {
  if (table_->sim == nullptr) return false;
  return table_->sim->set_start_pose(device_, instrument, position.data()) != 0;
}

void PluginDevice::set_hand(int instrument, const HandCouplings& hand) noexcept {
  if (table_->sim == nullptr) return;
  hl_hand_coupling raw[kNumDeviceJoints];
  for (int j = 0; j < kNumDeviceJoints; ++j) {
    const HandCoupling& h = hand[static_cast<std::size_t>(j)];
    raw[j] = {h.reference_position, h.reference_velocity, h.stiffness, h.damping, h.force, h.mass};
  }
  table_->sim->set_hand(device_, instrument, raw);
}

DeviceJoints PluginDevice::hand_force(int instrument) const noexcept {
  DeviceJoints f{};
  if (table_->sim != nullptr) table_->sim->hand_force(device_, instrument, f.data());
  return f;
}

DeviceJoints PluginDevice::motor_force(int instrument) const noexcept {
  DeviceJoints f{};
  if (table_->sim != nullptr) table_->sim->motor_force(device_, instrument, f.data());
  return f;
}

std::string check_ratings(const std::string& source, const DeviceRatings& ratings) {
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < kNumDeviceJoints; ++j) {
      const DeviceJointRating& r = ratings.joint[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)];
      const std::string where = source + " reports invalid ratings: " + kInstrumentNames[i] + " " + kJointNames[j] + " ";
      const std::pair<const char*, double> fields[] = {{"min_position", r.min_position},
                                                       {"max_position", r.max_position},
                                                       {"continuous_force", r.continuous_force},
                                                       {"peak_force", r.peak_force},
                                                       {"max_velocity", r.max_velocity}};
      for (const auto& [field, value] : fields)
        if (!std::isfinite(value)) return where + field + " is " + number(value) + "; it must be a finite number";
      if (!(r.max_position > r.min_position))
        return where + "max_position " + number(r.max_position) + " must be > min_position " + number(r.min_position);
      if (r.continuous_force < 0.0)
        return where + "continuous_force " + number(r.continuous_force) + " must be >= 0";
      if (r.peak_force < r.continuous_force)
        return where + "peak_force " + number(r.peak_force) + " must be >= continuous_force " +
               number(r.continuous_force);
      if (!(r.max_velocity > 0.0)) return where + "max_velocity " + number(r.max_velocity) + " must be > 0";
      const bool translation = j == kJointInsertion;
      const PlausibleRatings& p = kPlausibleRatings;
      const double travel = translation ? p.translation_travel_m : p.rotation_travel_rad;
      const double force = translation ? p.translation_force_N : p.rotation_torque_Nm;
      const double speed = translation ? p.translation_speed_m_per_s : p.rotation_speed_rad_per_s;
      const char* unit = translation ? " m" : " rad";
      for (const auto& [field, value] : {std::pair{"min_position", r.min_position}, {"max_position", r.max_position}})
        if (std::abs(value) > travel)
          return where + field + " " + number(value) + " is beyond +-" + number(travel) + unit +
                 ", more than any hand-held device travels (it would switch the range guard off)";
      if (r.peak_force > force)
        return where + "peak_force " + number(r.peak_force) + " is above " + number(force) +
               (translation ? " N" : " N·m") + ", more than any hand-held device exerts (it would switch the force "
                                             "clip off)";
      if (r.max_velocity > speed)
        return where + "max_velocity " + number(r.max_velocity) + " is above " + number(speed) + unit +
               "/s, faster than any hand moves an instrument (it would switch the speed guard off)";
    }
  return "";
}

// --- probe in a child process -------------------------------------------
//
// The child writes records to a pipe: "S<stage>\n" before each step, then
// "E<message>" (refused) or "K" (all steps passed), and leaves with _exit:
// no atexit handlers or static destructors of the parent's state.

namespace {

void write_all(int fd, const std::string& text) noexcept {
  const char* p = text.data();
  std::size_t left = text.size();
  while (left > 0) {
    const ssize_t n = ::write(fd, p, left);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return;
    p += n;
    left -= static_cast<std::size_t>(n);
  }
}

void report_stage(void* context, const char* stage) {
  write_all(*static_cast<int*>(context), std::string("S") + stage + "\n");
}

[[noreturn]] void run_probe_child(int fd, const std::string& path, const std::map<std::string, std::string>& options,
                                  const DeviceConfig& config) {
  // A crash must end the child by its signal, so the parent can name it;
  // a sanitizer's or the parent's handler would turn it into an exit code.
  for (int sig : {SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT}) ::signal(sig, SIG_DFL);
  try {
    int stage_fd = fd;
    PluginDevice device(path, options, &report_stage, &stage_fd);
    report_stage(&stage_fd, "configure");
    // configure() fetches and checks the ratings as well.
    const DeviceStatus status = device.configure(config);
    if (status != DeviceStatus::kOk) {
      write_all(fd, "E" + device.configure_error());
      ::_exit(0);
    }
    report_stage(&stage_fd, "destroy");
  } catch (const std::exception& e) {
    write_all(fd, std::string("E") + e.what());
    ::_exit(0);
  }
  write_all(fd, "K");
  ::_exit(0);
}

// The threads of this process (Linux's /proc/self/task); 0 if unknown.
std::size_t thread_count() {
  std::error_code error;
  std::size_t n = 0;
  for (std::filesystem::directory_iterator it("/proc/self/task", error), end; !error && it != end;
       it.increment(error))
    ++n;
  return error ? 0 : n;
}

}  // namespace

void probe_plugin(const std::string& path, const std::map<std::string, std::string>& options,
                  const DeviceConfig& config, double timeout_s) {
  // The child loads the plugin (dlopen, malloc): after fork, a lock another
  // thread held at that moment (the allocator's, the loader's) stays held
  // in the child for good, and the probe would blame the plugin for the
  // hang. So never fork a process with other threads.
  if (const std::size_t threads = thread_count(); threads != 1)
    throw std::runtime_error("plugin " + path + ": cannot probe it in a fork of this process, which runs " +
                             (threads == 0 ? std::string("an unknown number of") : std::to_string(threads)) +
                             " threads (a lock another thread holds would hang the copy); register a plugin "
                             "host (set_plugin_host_executable), as the hapticlab command does; nothing was started");
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0)  // not inherited by a process another thread starts meanwhile
    throw std::runtime_error("plugin " + path + ": cannot probe it (pipe: " + std::strerror(errno) + ")");
  const pid_t child = ::fork();
  if (child < 0) {
    const int err = errno;
    ::close(fds[0]);
    ::close(fds[1]);
    throw std::runtime_error("plugin " + path + ": cannot probe it (fork: " + std::strerror(err) + ")");
  }
  if (child == 0) {
    ::close(fds[0]);
    run_probe_child(fds[1], path, options, config);
  }
  ::close(fds[1]);

  // Read until the child closes its end (it exits), or the time is up.
  std::string record;
  bool timed_out = false;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  for (;;) {
    const double left_ms =
        std::chrono::duration<double, std::milli>(deadline - std::chrono::steady_clock::now()).count();
    if (left_ms <= 0.0) {
      timed_out = true;
      break;
    }
    pollfd p{fds[0], POLLIN, 0};
    const int ready = ::poll(&p, 1, static_cast<int>(std::ceil(left_ms)));
    if (ready < 0 && errno == EINTR) continue;
    if (ready <= 0) continue;
    char buffer[1024];
    const ssize_t n = ::read(fds[0], buffer, sizeof buffer);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    record.append(buffer, static_cast<std::size_t>(n));
  }
  ::close(fds[0]);
  if (timed_out) ::kill(child, SIGKILL);
  int wstatus = 0;
  while (::waitpid(child, &wstatus, 0) < 0 && errno == EINTR) {
  }

  // The last stage the child entered, and its verdict.
  std::string stage = "load";
  std::string verdict;
  std::size_t pos = 0;
  while (pos < record.size()) {
    if (record[pos] == 'S') {
      const std::size_t end = record.find('\n', pos);
      if (end == std::string::npos) break;
      stage = record.substr(pos + 1, end - pos - 1);
      pos = end + 1;
    } else {
      verdict = record.substr(pos);
      break;
    }
  }
  if (timed_out)
    throw std::runtime_error("plugin " + path + " did not return from " + stage + " within " + number(timeout_s) +
                             " s; nothing was started");
  if (WIFSIGNALED(wstatus))
    throw std::runtime_error("plugin " + path + " crashed (" + signal_name(WTERMSIG(wstatus)) + ") in " + stage +
                             "; nothing was started");
  if (!verdict.empty() && verdict[0] == 'E') throw std::runtime_error(verdict.substr(1));
  if (verdict != "K")
    throw std::runtime_error("plugin " + path + " ended the process (exit status " +
                             std::to_string(WIFEXITED(wstatus) ? WEXITSTATUS(wstatus) : -1) + ") in " + stage +
                             "; nothing was started");
}

}  // namespace hapticlab
