"""HID report descriptors and the generic, descriptor-driven pen parser.

``descriptor`` parses report descriptors into report layouts and extracts
fields from reports; ``pen`` turns a pen interface's reports into
:class:`station.drivers.raw.RawSample` values using only the descriptor.
"""
