"""Simulation parameters and paint profiles of the three-layer canvas.

Units used throughout the canvas package:

- length: one cell (cell width = cell height = 1);
- time: seconds of simulated paint time (``dt`` defaults to 1/30 s);
- water: height of a water column in cell units (``w`` and ``wc``);
- pigment: fraction of the cell area covered (``p`` and ``q``).

Every rate below is "per second"; a pass multiplies it by ``dt``. The numbers
are the station's decisions (see ``docs/canvas-model.md``): the seed gives only
``omega_h = 0.06`` and the 32x32 tiles.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from station.canvas.errors import CanvasInputError
from station.canvas.palette import Pigment

__all__ = ["FIBRE_CHANNEL", "BrushDefaults", "CanvasInputError", "Profile", "SimParams",
           "vapour_deficit"]

FIBRE_CHANNEL = 4.0
"""A cell full of fibre along an axis conducts the film's levelling flow along it this many
times the felt's mean (``SimParams.fibre_permeability``): one over the mean fibre share of
an axis on cold-press paper (0.21-0.22), so a wash's mean flow keeps its pace."""


def vapour_deficit(temperature: float, humidity: float) -> float:
    """``rho_sat(T) * (1 - RH)``: water vapour the air can still take [kg/m^3].

    Saturation vapour pressure by the Magnus formula (hPa), ideal-gas vapour density.
    """
    e_sat = 611.2 * math.exp(17.62 * temperature / (243.12 + temperature))  # Pa
    rho_sat = e_sat / (461.5 * (temperature + 273.15))
    return rho_sat * (1.0 - humidity)


@dataclass(frozen=True)
class SimParams:
    """Numerical and physical parameters of one simulation step.

    Attributes (units in brackets):
        dt: time step [s].
        w_min, w_max: bounds of the fluid water height inside a stroke [height].
            Advection never moves a cell out of ``[min(w, w_min), max(w, w_max)]``.
        viscosity: kinematic viscosity nu of the velocity diffusion [cell^2/s].
        jacobi_iters: Jacobi iterations of every implicit diffusion [count].
        omega_h: weight of the water-height velocity ``v_h`` in the blend (seed: 0.06).
        height_gain: ``v_h = -height_gain * grad(w)`` [cell/s per height/cell].
        nu_w: water diffusion rate [cell^2/s].
        nu_p: pigment diffusion rate [cell^2/s].
        eps_shallow: fluid-layer evaporation rate at the reference air (20 C, 50 % relative
            humidity, airflow 1) [height/s]; the passes use :meth:`evap_shallow`.
        edge_evap: factor on the extra side evaporation ``w * eps_shallow * dt`` per face
            towards a neighbour without fluid water (spec: 1, the default).
        flow_outward: Curtis 1997's flow-outward strength eta [height]: the pressure of
            the water-height term is lowered by ``eta * (1 - M')`` on wet cells, ``M'`` the
            wet mask blurred by a Gaussian of ``wet_blur`` cells, so water (and the pigment
            it carries) flows towards the pinned edge while the stroke dries.
        advance_height: a dry cell joins the wet area when a 4-neighbour's fluid water
            exceeds ``advance_height * (1.5 - h)`` [height] (0: pinned at the footprint);
            on paper damper than ``damp_sat`` ``advance_height * (1 + g/2 - g h)``;
        advance_grain: ``g``, how much the cell's paper height ``h`` sets that advancing
            height on damp paper [1]: 1 (the default) ``1.5 - h`` as on dry paper, 0 the
            same height on every damp cell. Read cell by cell, the paper's height blobs
            (several cells across) stop a front creeping into damp paper in blocks and
            notches of whole cells ("battlements").
        advance_curvature: ``a``, the meniscus's curvature on paper no damper than
            ``damp_sat`` [1]: a dry cell there is reached when its neighbourhood's water
            ``sum_4 w + a sum_diagonal w`` exceeds ``(1 + 2a)`` times its advancing height
            (a straight edge as before; a tip ahead of the front needs more water, a notch
            behind it less: surface tension). 0 (the default): a 4-neighbour's ``w`` above
            the advancing height. Without it, the per-cell height threshold let single
            columns run ahead, and the two-neighbour pinning grew them into rectangular
            tabs 2-3 cells across (a front crept into dry paper dried as battlements).
        fibre_wick: how far a paper fibre running along a face's axis lowers that
            advancing height, ``* (1 - fibre_wick * fibre)`` (``paper.make_fibres``; 1: the
            water runs freely along a whole fibre, the ink bleed of absorbent paper) [1];
            0: the fibre texture is not used.
            the contact line creeps on where the paper lets it, so edges follow the grain.
        fibre_dispersivity: longitudinal dispersivity of the paper's fibre channels [cells]
            (hydrodynamic dispersion in a porous medium, Bear 1972: ``D = alpha |v|``):
            where water moves at speed ``|v|`` through a cell crossed by fibres, suspended
            pigment disperses with ``nu_p + alpha * max(fibre[0], fibre[1]) * |v|``, i.e.
            the diffusion-controller value is multiplied by
            ``1 + (alpha / nu_p) * max(fibre) * |v|``; the pigment the brush's water pushes
            into a wet wash feathers along the fibres, a calm wash is untouched. 0: off.
        fibre_permeability: ``a``, how much the paper's fibre felt channels the film's
            levelling flow [1]: pass 3's water-height velocity along each axis is
            multiplied by ``(1 - a) + a * FIBRE_CHANNEL * fibre[axis]``
            (:data:`FIBRE_CHANNEL` = 4, about one over the mean fibre share of an axis on
            cold-press paper, so the mean conductance stays about 1). Water driven through
            wet paper runs along the fibres and is held by the felt between them (Darcy
            flow through a permeability that is uneven at the fibre scale): the paint a
            brush pushes into a wet wash goes out in fingers along the fibres, a feathered
            front, not a round blot. 0: off (every built-in profile for now: on with
            watercolor's ``nu_p`` 0.02 and ``fibre_dispersivity`` 9 it feathers a drop into a
            wet wash, but it also stops the levelling flow on fibre-less paper and weakens
            the rims and the damp-wash blooms). On paper without any fibre (hot-press)
            the factor is 1: there is no felt to channel the flow.
        fibre_gate_depth: the standing water [height] over which the fibre channel fades
            in: ``a`` above is ``a * smoothstep(w / fibre_gate_depth)`` per cell, so the
            channel acts where a wash still stands on saturated paper (a drop into a fully
            wet wash) and not on damp paper, where the flow outward carries the water to
            a bloom's or a stroke's edge. 0: no gate (``a`` everywhere).
        fibre_gate_pull: with ``fibre_gate_depth``, the flow-outward pull [height] at which
            the channel is off: the gate is also times ``1 - smoothstep(pull /
            fibre_gate_pull)``, ``pull = (w + paper_relief h) - P`` (pass 3's levelled
            height ``P`` lies ``flow_outward (1 - M')`` below the water near the edge of the
            wet area), so a front still spreading into dry paper keeps its flow outward
            and its rim, and only the inside of a wet wash is channelled (0.1
            ``flow_outward``: M' above 0.9). 0: no such factor.
        fibre_flow_max: the fastest water moves through the paper's fibre channels
            [cell/s] (capillary/Darcy flow in paper is about a millimetre per second); the
            fibre dispersion uses ``min(|v|, fibre_flow_max)``: a film the brush drives
            faster moves over the paper, not faster through it.
        standing_depth: the standing water [height] over which the pigment diffusion fades
            from ``nu_p`` to ``standing_nu_p``: ``nu_p (1 - g) + standing_nu_p g``,
            ``g = smoothstep(w / standing_depth)`` per cell (on the diffusion controller,
            so the fibre dispersion is untouched). Micron pigment in standing water hardly
            diffuses (Brownian, orders below a cell a second); ``nu_p``'s larger value
            stands for the mixing of a thin, drying film. 0: off (``nu_p`` everywhere).
        standing_nu_p: the pigment diffusion in standing water [cell^2/s], in
            ``[0, nu_p]`` (with ``standing_depth``).
        standing_front_pull: with ``standing_depth``, the flow-outward pull [height] at
            which the pigment keeps its own diffusion ``nu_p`` in standing water: the
            standing gate ``g`` is times ``1 - F``, ``F = smoothstep(flow_outward (1 - M')
            / standing_front_pull)`` (times the dry-paper factor below), ``M'`` the blurred
            wet-area mask of the flow-outward term: near the edge of a wet area the pile
            the flow carries out keeps the broad shape of a brush rim (2-5 cells) instead
            of standing in the outermost cell. 0: off.
        standing_front_dry: with ``standing_front_pull``, the front factor only where the
            paper outside is dry: ``F`` is times ``min(2 D, 1)``, ``D = 1 - blur(wc >=
            standing_front_dry c)`` (the wet mask's blur, ``c`` the capacity; cells
            outside the simulated area are at rest, so dry): a stroke's edge on dry paper
            (D about 0.5) keeps it, a bloom's front inside a damp wash (D about 0) keeps
            the low diffusion. In ``[0, 1]`` [share of capacity]; 0: every front.
        paper_relief: relief of the paper under the water [height per unit of ``h``]: the
            water-height term levels the free surface ``w + paper_relief * h``, so water
            runs off the paper's hills into its valleys (Curtis 1997's flow down the paper
            texture) and a flowing front frays along them.
        wet_hold: how long a cell stays in Curtis's wet-area mask ``M`` after its own
            water is gone [s] (0: off, ``M`` is the cells wet by their own water). ``M``
            (``CanvasState.wet_area``, in [0, 1]) is 1 where a cell holds fluid water (or
            capillary water above ``moist_threshold``); once the fluid is gone it fades by
            ``dt / wet_hold`` per step while the paper is damp, and is 0 once the paper
            has dried (``wc == 0``). Flow outward acts at the edge of ``M``: a thin strip
            drying inside a still-wet wash is no edge, so the water is not pulled into a
            line there (Curtis et al. 1997, section 4.3: the wet-area mask of a glaze only
            grows while it is wet; the flow outward pins the pigment at its edge).
        wet_blur: standard deviation of the Gaussian that blurs the wet mask [cells]
            (0: no flow-outward term); the kernel is truncated at ``ceil(2 * wet_blur)``.
        rim_sharpness: the share ``k`` (0 ... 1) of the flow-outward pull that follows the
            contact line's own reach instead of the blur's: the pull is ``flow_outward
            ((1 - k) u + k s)``, ``u = 1 - M'`` the dry share of the blurred neighbourhood
            and ``s = clamp((u - rim_onset) / (rim_full - rim_onset), 0, 1)`` (0: the blur
            alone, as before). ``u`` falls with the distance from the edge, so ``s`` is
            full on the outermost cells and 0 a few cells in, on a narrow stroke as on a
            wide one: the water pools in a band at the pinned edge, not over the whole
            width the blur spans (:meth:`rim_profile`).
        rim_onset, rim_full: the dry shares ``u`` at which the sharp pull starts and is
            full (``rim_onset < rim_full`` when ``rim_sharpness > 0``).
        alpha: capillary absorption rate [height/s].
        cap_diffusion: capillary diffusion rate kappa on the saturation difference [1/s];
            ``cap_diffusion * dt <= 1/8`` keeps ``wc`` inside ``[0, c]`` exactly.
        eps_cap: capillary evaporation rate at the reference air [height/s]; the passes
            use :meth:`evap_cap`.
        temperature: air (and paper) temperature [degrees C], -10 ... 60.
        humidity: relative humidity of the air [1], 0 ... 0.99.
        airflow: mass-transfer factor of the air movement over the sheet relative to the
            reference draught [1] (evaporation is proportional to it).
        c_min, c_max: capillary capacity at paper height 0 and 1 [height].
        moist_threshold: ``wc`` above which a cell is moist, hence wet [height].
        damp_ease: suction of damp paper on the contact line [1] (0: off): the advancing
            height is multiplied by ``max(1 - damp_ease * 4 s' (1 - s'), 0)``, where
            ``s' = max(s - damp_sat, 0) / (1 - damp_sat)`` rescales the capillary layer's
            saturation ``s = wc / c`` above ``damp_sat``. Paper drier than ``damp_sat``
            (dry paper, the capillary halo of a stroke) pins the front as before; a full
            capillary layer has no suction left; damp paper in between draws fresh water
            in. Water put into a damp wash therefore runs on where the wash is still
            unsaturated and stalls where its own capillary halo has filled the paper: the
            front grows lobes into the drier paper (Curtis et al. 1997, section 4.7: the
            wet-area mask grows by capillary flow into damp cells, none into paper drier
            than their delta; fig. 1c).
        damp_sat: saturation ``wc / c`` above which paper counts as damp for
            ``damp_ease`` [1], 0 ... 0.99 (Curtis's delta).
        damp_exposure: the least exposure of a damp cell the contact line reaches for it
            to join [1], 0 ... 1 (0: off; needs ``flow_outward`` and ``wet_blur``): a cell
            on paper damper than ``damp_sat``, not wet by its own water, joins only where
            ``1 - M'`` >= ``damp_exposure``, ``M'`` the flow-outward term's blurred
            wet-area mask at the start of the step (a straight front's next cell reads
            about 0.55 with a 4-cell blur). The damp paper ahead of fresh water is full of
            the wash's paint, which the water must push on; it gives way where it has
            paper around it to go to (a convex part of the front) and holds in a bay: a
            dielectric-breakdown reading of the displaced paint's pressure (Saffman-Taylor),
            with the blurred mask standing in for its Laplacian field. The front runs on at
            its bulges and a bloom branches (Curtis et al. 1997 fig. 1c).
        suspend_sat: saturation ``wc / c`` above which a cell without fluid water keeps
            its pigment in suspension instead of depositing it [1], 0 ... 1 (0: off, every
            cell without fluid water deposits). Gum arabic stays soft while the paper is
            damp, so water flowing back into a damp wash lifts and carries its pigment
            (Curtis 1997, 4.7 backruns; Smith, "The Watercolour Painter's Handbook":
            blooms form only while the wash is damp, not once it has dried).
        lift_gain: desorption over adsorption rate of the surface exchange [1] (1: the
            seed's eq. 4.12 as it is): pass 8 lifts with the pigment's staining
            ``beta / lift_gain``. Pigment that settled out of a wet wash sits loose on the
            sized paper until the gum dries; returning water takes it up again several
            times faster than it settled (Curtis et al. 1997, "Transferring pigment":
            desorption; the seed's eq. 4.12, section 4.6; Smith, "The
            Watercolour Painter's Handbook": a wet wash lifts at a touch, a dried one
            hardly), so water put back into a damp wash carries the settled pigment to the
            bloom's front. Staining pigments (large ``beta``) still lift least.
        v_max: bound of each velocity component [cell/s]; ``v_max * dt <= 1``.
        surface_rate: factor on the surface exchange of eqs. 4.11/4.12 [1/s] (spec: 1;
            default 0.5 keeps pigment suspended long enough to travel to the rim).
        block_paper: share of the paper height in the diffusion-controller blocking
            value, ``beta_paper = 1 - block_paper * (1 - h)`` [1].
        block_fade: time for a brush-written blocking pattern to fade to "free" [s].
        w_dry_eps: fluid water below which a cell dries (the rest evaporates) [height].
        tile_size: dirty-tile edge [cells].
        tile_check: steps between re-checks of a tile's time-to-live [steps] (0: from
            the drying-time estimate).
        paper_shade: darkening of paper valleys in the blank paper reflectance [1].
        gouache_opaque: pigment thickness at which a gouache layer hides what is below [1].
        gouache_white: share of the implicit white filler in a gouache body colour [1].
        render_bands: Kubelka-Munk bands of the render [count]: 12 (spectral, 400-700 nm,
            to colour through the CIE 1931 observer) or 3 (Curtis's RGB channels).
        tilt: angle of the canvas from the horizontal [degrees], 0 ... 90 (0: flat).
        tilt_direction: downhill direction on the canvas [degrees from +x towards +y]
            (90: the top edge is raised, paint runs towards the bottom row).
        gravity: acceleration of a film of paint on a vertical sheet [cell/s^2]; pass 3
            adds ``gravity * sin(tilt) * (cos, sin)(tilt_direction) * dt`` to the velocity
            of wet cells (the omega_h blend damps it to a terminal speed of
            ``gravity * sin(tilt) * dt / omega_h``).
    """

    dt: float = 1.0 / 30.0
    w_min: float = 0.02
    w_max: float = 1.0
    viscosity: float = 0.5
    jacobi_iters: int = 4
    omega_h: float = 0.06
    height_gain: float = 100.0
    nu_w: float = 0.1
    nu_p: float = 0.3
    eps_shallow: float = 0.01
    edge_evap: float = 1.0
    flow_outward: float = 0.3
    advance_height: float = 0.7
    advance_grain: float = 1.0
    advance_curvature: float = 0.0
    paper_relief: float = 0.0
    wet_blur: float = 2.0
    rim_sharpness: float = 0.0
    rim_onset: float = 0.22
    rim_full: float = 0.36
    wet_hold: float = 0.0
    alpha: float = 0.03
    cap_diffusion: float = 1.5
    fibre_wick: float = 0.0
    fibre_dispersivity: float = 0.0
    fibre_permeability: float = 0.0
    fibre_gate_depth: float = 0.0
    fibre_gate_pull: float = 0.0
    standing_depth: float = 0.0
    standing_nu_p: float = 0.0
    standing_front_pull: float = 0.0
    standing_front_dry: float = 0.0
    fibre_flow_max: float = 2.0
    eps_cap: float = 0.004
    temperature: float = 20.0
    humidity: float = 0.5
    airflow: float = 1.0
    c_min: float = 0.1
    c_max: float = 0.4
    moist_threshold: float = 0.25
    damp_ease: float = 0.0
    damp_sat: float = 0.0
    damp_exposure: float = 0.0
    suspend_sat: float = 0.0
    lift_gain: float = 1.0
    v_max: float = 30.0
    surface_rate: float = 0.1
    block_paper: float = 0.0
    block_fade: float = 2.0
    w_dry_eps: float = 1e-5
    tile_size: int = 32
    tile_check: int = 0
    paper_shade: float = 0.05
    gouache_opaque: float = 0.6
    gouache_white: float = 0.25
    render_bands: int = 12
    tilt: float = 0.0
    tilt_direction: float = 90.0
    gravity: float = 100.0

    def __post_init__(self) -> None:
        self.validate()

    def validate(self) -> None:
        """Raise :class:`CanvasInputError` unless every parameter is usable."""
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if not isinstance(value, (int, float)) or isinstance(value, bool):
                raise CanvasInputError(f"parameter {f.name} must be a number", "params")
            if not math.isfinite(value) or value < 0:
                raise CanvasInputError(f"parameter {f.name} must be finite and >= 0", "params")
        if self.dt <= 0:
            raise CanvasInputError("dt must be > 0", "params")
        if not 0 <= self.w_min < self.w_max:
            raise CanvasInputError("need 0 <= w_min < w_max", "params")
        if not 0 < self.c_min <= self.c_max:
            raise CanvasInputError("need 0 < c_min <= c_max", "params")
        if not 0 <= self.omega_h <= 1:
            raise CanvasInputError("omega_h must lie in [0, 1]", "params")
        if self.v_max * self.dt > 1.0 + 1e-9:
            raise CanvasInputError("v_max * dt must be <= 1 cell per step", "params")
        if self.cap_diffusion * self.dt > 0.125 + 1e-9:
            raise CanvasInputError("cap_diffusion * dt must be <= 1/8", "params")
        if self.tile_size < 4 or int(self.tile_size) != self.tile_size:
            raise CanvasInputError("tile_size must be an integer >= 4", "params")
        if int(self.jacobi_iters) != self.jacobi_iters or self.jacobi_iters < 1:
            raise CanvasInputError("jacobi_iters must be an integer >= 1", "params")
        if not 0 <= self.gouache_white <= 1:
            raise CanvasInputError("gouache_white must lie in [0, 1]", "params")
        if self.render_bands not in (3, 12):
            raise CanvasInputError("render_bands must be 3 (RGB) or 12 (spectral)", "params")
        if self.wet_blur > 4:
            raise CanvasInputError("wet_blur must be <= 4 cells", "params")
        if not 0 <= self.rim_sharpness <= 1:
            raise CanvasInputError("rim_sharpness must lie in [0, 1]", "params")
        if self.rim_full > 1 or (self.rim_sharpness > 0 and not self.rim_onset < self.rim_full):
            raise CanvasInputError("need rim_onset < rim_full <= 1", "params")
        if not -10 <= self.temperature <= 60:
            raise CanvasInputError("temperature must lie in [-10, 60] C", "params")
        if not 0 <= self.humidity <= 0.99:
            raise CanvasInputError("humidity must lie in [0, 0.99]", "params")
        if not 0 <= self.advance_grain <= 1:
            raise CanvasInputError("advance_grain must lie in [0, 1]", "params")
        if not 0 <= self.advance_curvature <= 4:
            raise CanvasInputError("advance_curvature must lie in [0, 4]", "params")
        if not 0 <= self.fibre_wick <= 1:
            raise CanvasInputError("fibre_wick must be in [0, 1]", "params")
        if not 0 <= self.fibre_permeability <= 1:
            raise CanvasInputError("fibre_permeability must lie in [0, 1]", "params")
        if not 0 <= self.fibre_gate_depth <= 10:
            raise CanvasInputError("fibre_gate_depth must lie in [0, 10]", "params")
        if not 0 <= self.fibre_gate_pull <= 10:
            raise CanvasInputError("fibre_gate_pull must lie in [0, 10]", "params")
        if not 0 <= self.standing_depth <= 10:
            raise CanvasInputError("standing_depth must lie in [0, 10]", "params")
        if not 0 <= self.standing_nu_p <= self.nu_p:
            raise CanvasInputError("standing_nu_p must lie in [0, nu_p]", "params")
        if not 0 <= self.standing_front_pull <= 10:
            raise CanvasInputError("standing_front_pull must lie in [0, 10]", "params")
        if not 0 <= self.standing_front_dry <= 1:
            raise CanvasInputError("standing_front_dry must lie in [0, 1]", "params")
        if self.fibre_dispersivity > 100:
            raise CanvasInputError("fibre_dispersivity must be <= 100 cells", "params")
        if not 0 <= self.damp_sat <= 0.99:
            raise CanvasInputError("damp_sat must lie in [0, 0.99]", "params")
        if self.damp_ease > 1000:
            raise CanvasInputError("damp_ease must lie in [0, 1000]", "params")
        if not 0 <= self.damp_exposure <= 1:
            raise CanvasInputError("damp_exposure must lie in [0, 1]", "params")
        if not 0 <= self.suspend_sat <= 1:
            raise CanvasInputError("suspend_sat must lie in [0, 1]", "params")
        if self.wet_hold > 600:
            raise CanvasInputError("wet_hold must lie in [0, 600] s", "params")
        if not 0 < self.lift_gain <= 100:
            raise CanvasInputError("lift_gain must lie in (0, 100]", "params")
        if not 0 <= self.block_paper <= 1:
            raise CanvasInputError("block_paper must lie in [0, 1]", "params")
        if not 0 <= self.tilt <= 90:
            raise CanvasInputError("tilt must lie in [0, 90] degrees", "params")
        if not 0 <= self.tilt_direction < 360:
            raise CanvasInputError("tilt_direction must lie in [0, 360) degrees", "params")

    def tilt_acceleration(self) -> tuple[float, float]:
        """Downhill acceleration of the paint film (x, y) [cell/s^2]; (0, 0) when flat."""
        if self.tilt == 0 or self.gravity == 0:
            return 0.0, 0.0
        g = self.gravity * math.sin(math.radians(self.tilt))
        a = math.radians(self.tilt_direction)
        # cos(90 deg) is 6e-17 in floating point: a slope straight down must not creep sideways
        ca, sa = (0.0 if abs(t) < 1e-12 else t for t in (math.cos(a), math.sin(a)))
        return g * ca, g * sa

    def drying_power(self) -> float:
        """Evaporation relative to the reference air (20 C, 50 %, airflow 1) [1].

        Evaporation is mass transfer driven by the vapour-density deficit of the air,
        ``airflow * rho_sat(T) * (1 - RH)`` (rho_sat from the Magnus formula); exactly 1.0
        at the reference conditions.
        """
        ref = vapour_deficit(20.0, 0.5)
        return float(self.airflow) * vapour_deficit(self.temperature, self.humidity) / ref

    def evap_shallow(self) -> float:
        """Fluid-layer evaporation rate in this air [height/s]."""
        return self.eps_shallow * self.drying_power()

    def evap_cap(self) -> float:
        """Capillary-layer evaporation rate in this air [height/s]."""
        return self.eps_cap * self.drying_power()

    def fibre_dispersion_gain(self) -> float:
        """``fibre_dispersivity / nu_p`` [s/cell]: the factor on ``max(fibre) * |v|`` in
        beta_c (0 when either is 0)."""
        if self.fibre_dispersivity <= 0 or self.nu_p <= 0:
            return 0.0
        return self.fibre_dispersivity / self.nu_p

    def fibre_channel(self) -> tuple[float, float]:
        """``(1 - a, FIBRE_CHANNEL * a)`` as float32 values, ``a`` = ``fibre_permeability``:
        pass 3's water-height velocity along an axis is multiplied by
        ``base + gain * fibre[axis]`` (both rounded once, as every backend uses them)."""
        a = self.fibre_permeability
        return float(np.float32(1.0 - a)), float(np.float32(FIBRE_CHANNEL * a))

    def rim_profile(self) -> tuple[float, float, float, float]:
        """``(k, 1 - k, rim_onset, 1 / (rim_full - rim_onset))`` as float32 values (all 0
        when ``rim_sharpness`` is 0): the flow-outward pull is ``flow_outward ((1 - k) u +
        k min(max((u - rim_onset) inv, 0), 1))``, ``u = 1 - M'``
        (stencils.outward_pull)."""
        k = self.rim_sharpness
        if k <= 0:
            return 0.0, 0.0, 0.0, 0.0
        f32 = np.float32
        return (float(f32(k)), float(f32(1.0 - k)), float(f32(self.rim_onset)),
                float(f32(1.0 / (self.rim_full - self.rim_onset))))

    def fibre_gate(self) -> float:
        """``1 / fibre_gate_depth`` as a float32 value (0: no gate): the channel's gate is
        ``smoothstep(w * fibre_gate())`` (passes.standing_gate)."""
        if self.fibre_gate_depth <= 0:
            return 0.0
        return float(np.float32(1.0 / self.fibre_gate_depth))

    def fibre_gate_front(self) -> float:
        """``1 / fibre_gate_pull`` as a float32 value (0: no front factor)."""
        if self.fibre_gate_pull <= 0:
            return 0.0
        return float(np.float32(1.0 / self.fibre_gate_pull))

    def standing_diffusion(self) -> tuple[float, float]:
        """``(1 / standing_depth, 1 - standing_nu_p / nu_p)`` as float32 values, ``(0, 0)``
        when off: the diffusion controller is multiplied by ``1 - drop * g``,
        ``g = smoothstep(w * inv)`` (passes.standing_gate)."""
        if self.standing_depth <= 0 or self.nu_p <= 0:
            return 0.0, 0.0
        return (float(np.float32(1.0 / self.standing_depth)),
                float(np.float32(1.0 - self.standing_nu_p / self.nu_p)))

    def standing_front(self) -> tuple[float, float]:
        """``(1 / standing_front_pull, standing_front_dry)`` as float32 values, ``(0, 0)``
        when the front factor is off: without ``standing_depth``, without a pull
        (``standing_front_pull``, ``flow_outward`` or ``wet_blur`` 0)."""
        if (self.standing_front_pull <= 0 or self.standing_diffusion()[0] <= 0
                or self.flow_outward <= 0 or self.wet_blur <= 0):
            return 0.0, 0.0
        return (float(np.float32(1.0 / self.standing_front_pull)),
                float(np.float32(self.standing_front_dry)))

    def replace(self, **changes: Any) -> SimParams:
        """A copy with ``changes`` applied (validated)."""
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict[str, object]:
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> SimParams:
        names = {f.name for f in dataclasses.fields(cls)}
        unknown = set(data) - names
        if unknown:
            raise CanvasInputError(f"unknown parameters {sorted(unknown)}", "params")
        kinds = {f.name: f.type for f in dataclasses.fields(cls)}
        clean: dict[str, Any] = {}
        for k, v in data.items():
            clean[k] = int(v) if kinds[k] in ("int", int) else float(v)
        return cls(**clean)

    def tile_ttl_steps(self) -> int:
        """Time-to-live of a touched tile: an estimate of the drying time in steps.

        Fluid water of height ``w_max`` evaporates at ``eps_shallow`` and is absorbed
        at ``alpha``; a full capillary tank then evaporates at ``eps_cap``.
        """
        if self.tile_check > 0:
            return int(self.tile_check)
        fluid = self.w_max / max(self.evap_shallow() + self.alpha, 1e-6)
        cap = self.c_max / max(self.evap_cap(), 1e-6)
        return max(1, min(int(math.ceil((fluid + cap) / self.dt / 4.0)), 4096))


@dataclass(frozen=True)
class BrushDefaults:
    """Defaults the round brush of a profile starts from.

    radius [cells] at full pressure; water [height] deposited per stamp at full pressure;
    pigment_load [KM thickness per cell]: pigment a full-pressure stamp of tube-strength
    paint (brush amount 1) lays in one pass, in the units of the palette's K and S (K d is
    the layer's optical depth). 1.0 is calibrated on appearance (issue 21): one
    full-strength pass of a dark pigment then measures 0.4-0.6 darkness, as real strokes do
    on Curtis et al.'s scans (0.20-0.62), and amount 0.03 a tint below 0.08. The brush
    amount is the paint's concentration relative to tube strength: pigment per unit of
    water = amount x pigment_load / water, so thinning is linear in it. amount: the brush
    amount the profile starts with (a mid wash, 1/4 of tube strength) [1]; pigment: the
    default pigment name.
    """

    radius: float = 6.0
    water: float = 0.5
    pigment_load: float = 1.0
    pigment: str = "French Ultramarine"
    amount: float = 0.25


@dataclass(frozen=True)
class Profile:
    """A paint medium: simulation parameters, paper, palette, renderer, brush.

    ``pigments`` names the palette in order; ``pigment_defs`` holds the same pigments with
    their Kubelka-Munk and surface properties as the profile file gives them.
    """

    name: str
    params: SimParams
    paper: str
    renderer: str  # "km" or "gouache"
    pigments: tuple[str, ...]
    brush: BrushDefaults = field(default_factory=BrushDefaults)
    description: str = ""
    pigment_defs: tuple[Pigment, ...] = ()
    source: str = ""  # the file it was read from
