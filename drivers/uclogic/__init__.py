"""UC-Logic tablets (Huion, Gaomon, XP-Pen/UGEE …): set-up, parameters, pen reports.

``params``: the parameter string descriptors read as numbers; ``init``: the
set-up sequence the kernel's hid-uclogic driver performs, over any
:class:`~station.drivers.uclogic.init.UclogicControl`; ``parser``: the pen
reports before and after the switch to full resolution.
"""
