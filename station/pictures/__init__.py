"""Picture makers: the effects sheet, the brush sheet, the tools sheet, the bundled
demo painting, and the scenarios and measures they use. This room may sit above the
sim (it plays session scripts through :class:`~station.sim.player.SessionPlayer`);
nothing below it imports it."""
