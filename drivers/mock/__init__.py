"""Mock devices that behave as real backends, chosen by configuration (device SPECs).

- :mod:`~station.drivers.mock.tablet`: ``mock:MODEL`` — scripted strokes as a
  model's real report bytes (mouse mode until the ``02 02`` switch);
- :mod:`~station.drivers.mock.hidraw`: a hidraw node over a SOCK_SEQPACKET
  socket serving reports and logging feature reports (``mock-hidraw:``);
- :mod:`~station.drivers.mock.usb`: a pyusb backend presenting a recorded
  device through pyusb's API (``mock-usb:``);
- :mod:`~station.drivers.mock.evdev`: kernel-style event frames from scripts
  and an evdev node with python-evdev's interface (``mock-evdev:``);
- :mod:`~station.drivers.mock.script`: the pen scripts and USB-frame report times.
"""
