"""The simulation process side of the station: session player, live sim, scripted input, demo."""
