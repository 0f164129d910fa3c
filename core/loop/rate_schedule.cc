// filled in by the device/loop work
