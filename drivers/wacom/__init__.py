"""Wacom protocol parsers (byte layouts of the Linux wacom_wac driver).

``intuos``: Intuos family 10-byte report 2; ``bamboo``: Bamboo / Intuos-HT
pen 9/10 bytes; ``graphire``: Graphire 8-byte (USB report 2, Bluetooth
report 3); ``tools``: tool id -> tool type; ``modes``: the mouse-mode switch.
"""
