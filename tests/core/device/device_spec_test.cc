#include "core/device/device_spec.h"

#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

#include "core/device/device_factory.h"

namespace hapticlab {
namespace {

TEST(DeviceSpec, ParsesEveryBackend) {
  EXPECT_EQ(parse_device_spec("sim").kind, DeviceSpec::Kind::kSim);
  const DeviceSpec plugin = parse_device_spec("plugin:/opt/lab/libmydevice.so");
  EXPECT_EQ(plugin.kind, DeviceSpec::Kind::kPlugin);
  EXPECT_EQ(plugin.path, "/opt/lab/libmydevice.so");
  // "plugin:" is isolated where isolation costs under 20 µs at p99: with a
  // real-time loop.
  EXPECT_FALSE(plugin.isolated());
  DeviceSpec realtime = plugin;
  realtime.realtime_loop = true;
  EXPECT_TRUE(realtime.isolated());
  EXPECT_EQ(plugin.describe(), "plugin:/opt/lab/libmydevice.so");
  // Either way on request, and said so wherever the spec is shown.
  const DeviceSpec isolated = parse_device_spec("plugin-isolated:/opt/lab/libmydevice.so");
  EXPECT_EQ(isolated.kind, DeviceSpec::Kind::kPlugin);
  EXPECT_TRUE(isolated.isolated());
  EXPECT_EQ(isolated.path, "/opt/lab/libmydevice.so");
  EXPECT_EQ(isolated.describe(), "plugin-isolated:/opt/lab/libmydevice.so");
  DeviceSpec in_process = parse_device_spec("plugin-inprocess:/opt/lab/libmydevice.so");
  EXPECT_FALSE(in_process.isolated());
  in_process.realtime_loop = true;  // what the operator asked for wins
  EXPECT_FALSE(in_process.isolated());
  EXPECT_EQ(in_process.describe(), "plugin-inprocess:/opt/lab/libmydevice.so");
  const DeviceSpec udp = parse_device_spec("udp:10.0.0.7:5005");
  EXPECT_EQ(udp.kind, DeviceSpec::Kind::kUdp);
  EXPECT_EQ(udp.host, "10.0.0.7");
  EXPECT_EQ(udp.port, 5005);
  EXPECT_EQ(udp.describe(), "udp:10.0.0.7:5005");
  const DeviceSpec loopback = parse_device_spec("udp:6000");
  EXPECT_EQ(loopback.host, "127.0.0.1");  // loopback by default
  EXPECT_EQ(loopback.port, 6000);
}

TEST(DeviceSpec, RefusesMalformedSpecsNamingTheText) {
  for (const char* bad : {"lsw", "", "plugin:", "plugin-isolated:", "plugin-inprocess:", "udp:", "udp:0", "udp:65536",
                          "udp:host:", "udp::5000", "udp:12ab"}) {
    try {
      parse_device_spec(bad);
      ADD_FAILURE() << "accepted '" << bad << "'";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("'" + std::string(bad) + "'"), std::string::npos) << e.what();
    }
  }
}

TEST(DeviceSpec, OptionsAreKeyValueAndUnique) {
  DeviceSpec spec = parse_device_spec("udp:5000");
  add_device_options(spec, {"timeout_ms=20", "note=a=b"});
  EXPECT_EQ(spec.options.at("timeout_ms"), "20");
  EXPECT_EQ(spec.options.at("note"), "a=b");
  EXPECT_THROW(add_device_options(spec, {"timeout_ms=5"}), std::invalid_argument);
  EXPECT_THROW(add_device_options(spec, {"novalue"}), std::invalid_argument);
  EXPECT_THROW(add_device_options(spec, {"=1"}), std::invalid_argument);
}

TEST(DeviceFactory, TheSimDeviceIsHeldByASimulatedHandAndTakesNoOptions) {
  const auto device = open_device(parse_device_spec("sim"));
  ASSERT_NE(device, nullptr);
  EXPECT_NE(device->hand_attachment(), nullptr);
  DeviceSpec spec;
  spec.options["gain"] = "2";
  EXPECT_THROW(open_device(spec), std::invalid_argument);
}

TEST(DeviceFactory, TheUdpDeviceTakesOnlyATimeoutInItsRange) {
  // Options are checked before any packet goes out, so no driver is needed.
  for (const char* bad : {"timeout_ms=0", "timeout_ms=1001", "timeout_ms=10ms", "timeout_ms="}) {
    DeviceSpec spec = parse_device_spec("udp:5000");
    add_device_options(spec, {bad});
    try {
      open_device(spec);
      ADD_FAILURE() << bad;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("timeout_ms"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("1..1000"), std::string::npos) << e.what();
    }
  }
  DeviceSpec spec = parse_device_spec("udp:5000");
  add_device_options(spec, {"gain=2"});
  try {
    open_device(spec);
    ADD_FAILURE() << "took an unknown option";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("'gain' is not an option of the udp:127.0.0.1:5000 device"),
              std::string::npos)
        << e.what();
  }
}

TEST(DeviceFactory, AnUnauthenticatedBridgeBeyondLoopbackIsRefusedBeforeAnyDatagram) {
  // 192.0.2.1 (TEST-NET-1) answers nothing: a refusal here cannot have
  // come from a handshake that failed.
  DeviceSpec spec = parse_device_spec("udp:192.0.2.1:5000");
  for (const auto& check : {+[](const DeviceSpec& s) { (void)open_device(s); }, +[](const DeviceSpec& s) {
                              check_device_spec(s);
                            }}) {
    try {
      check(spec);
      ADD_FAILURE() << "an unauthenticated bridge to 192.0.2.1 was accepted";
    } catch (const std::invalid_argument& e) {
      const std::string why = e.what();
      EXPECT_NE(why.find("udp:192.0.2.1:5000: refused"), std::string::npos) << why;
      EXPECT_NE(why.find("not a loopback address, has no key"), std::string::npos) << why;
      EXPECT_NE(why.find("hapticlab device keygen --out bridge.key"), std::string::npos) << why;
      EXPECT_NE(why.find("--device-option key_file=bridge.key"), std::string::npos) << why;
      EXPECT_NE(why.find("--insecure"), std::string::npos) << why;
    }
  }
  spec.insecure = true;
  EXPECT_NO_THROW(check_device_spec(spec));
  // Any 127.x.y.z is loopback, and needs neither.
  EXPECT_NO_THROW(check_device_spec(parse_device_spec("udp:127.0.0.2:5000")));
  // --insecure means nothing for another backend, or beside a key: refused, not ignored.
  DeviceSpec sim = parse_device_spec("sim");
  sim.insecure = true;
  EXPECT_THROW(check_device_spec(sim), std::invalid_argument);
  add_device_options(spec, {"key_file=/nonexistent/bridge.key"});
  try {
    check_device_spec(spec);
    ADD_FAILURE() << "took --insecure with a key file";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("--insecure and device-option key_file"), std::string::npos) << e.what();
  }
  spec.insecure = false;
  try {
    check_device_spec(spec);
    ADD_FAILURE() << "took a key file that does not exist";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("device-option key_file: /nonexistent/bridge.key: cannot open it"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace hapticlab
