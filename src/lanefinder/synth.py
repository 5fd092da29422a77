"""Synthetic dashcam sequences with exactly known lane geometry (ground truth for ``lanefinder eval``).

The road is modelled in the car's level frame: X right, Y down, Z forward, the road plane
at Y = camera height.  The lane centre is a cubic in distance ahead,
x_c(Z) = -offset + heading*Z + curvature/2*Z^2 + curvature_rate/6*Z^3, and the lines are
at x_c -/+ width/2 (lateral distances, as the pipeline measures them).  Every pixel of the
*distorted* frame casts its ray (the exact inverse lens model, ``cv2.undistortPoints``) onto
the road, 2x2 samples per pixel, so undistorting a frame gives the pinhole rendering back.
Textures, dashes and shadows are anchored to the road (distance travelled + Z), so they move
consistently from frame to frame.

Ground truth per frame is taken where the pipeline measures: at the bird's-eye bottom row,
``z_near`` metres ahead (see docs/conventions.md): curvature, radius, offset, width, and
each line's x in the distorted frame at the TuSimple rows.

The road has two lanes: the car's first lane, between the yellow line (left) and a dashed
white line, and a lane to its right, up to a solid white line.  A scenario's manoeuvres move the
car across the road (and turn it, as a car must to move sideways); the truth always refers to
the *ego lane*, the lane that holds the camera, so after a change to the right lane its lines are
the dashed and the solid white lines.  ``events_gt.jsonl`` holds the true lane events, found
with :func:`lanefinder.events.detect_events` on the exact per-frame geometry.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterator
from dataclasses import asdict, dataclass, field, replace
from fractions import Fraction
from pathlib import Path

import cv2
import numpy as np

from .camera import CameraModel
from .config import LANE_SPAN_PX, LANE_WIDTH_M, VIEW_SIZE_PX, default_dst
from .errors import LaneFinderError
from .io import OutputSet, atomic_write_text, check_outputs
from .telemetry import h_samples as tusimple_rows

__all__ = [
    "DASH_M",
    "DASH_PATTERNS_M",
    "GAP_M",
    "LATERAL_AT_M",
    "LEFT_KINDS",
    "MARKING_M",
    "RENDER_BUDGET_MB",
    "RENDER_BYTES_PER_PX",
    "SCENARIOS",
    "Appearance",
    "Conditions",
    "FrameTruth",
    "Marking",
    "Mount",
    "NightLight",
    "Renderer",
    "Scenario",
    "Vehicle",
    "check_render_memory",
    "level_to_camera",
    "manoeuvre_shift",
    "road_start_s",
    "write_sequence",
]

#: Dash and gap lengths of a dashed line, m (US highway: 10 ft dashes, 30 ft gaps).
DASH_M, GAP_M = 3.0, 9.0
#: Marking width, m.
MARKING_M = 0.15
#: Distances ahead of the camera, m, at which the truth gives each line's lateral position.
LATERAL_AT_M = (6.0, 20.0)
#: Glare: the frame is this much brighter, plus this many grey levels times the glow.
GLARE_GAIN, GLARE_GLOW = 1.45, 170.0
#: A wet road at night returns this share of the light a dry one does, and its paint this share of
#: its shine beyond the road's (a film of water mirrors the beams away).
WET_ALBEDO, WET_RETRO = 0.7, 0.4
#: Paint less than this many grey levels lighter than the road around it is not visible (not labelled).
MIN_VISIBLE_CONTRAST = 6.0
#: On a road with crests and sags, the farthest road drawn, m (beyond it: haze, drawn as sky).  Rays
#: are traced from ``HILL_RAY_SLOPE`` above the level horizon down, so at the deepest sag of
#: ``hills`` the road drawn ends sooner, at about 160-180 m: beyond the truth's reach (150 m at most).
HILL_VIEW_M = 250.0
#: On a road with crests and sags, rays up to this slope above the level horizon may meet a rising road.
HILL_RAY_SLOPE = 0.08


@dataclass(frozen=True)
class Mount:
    """Where the camera sits on the car.

    Attributes
    ----------
    height_m : float
        Height above the road, m.
    pitch_deg : float
        Pitch down, degrees.
    yaw_deg : float
        Yaw to the right of the car's heading, degrees.

    Examples
    --------
    >>> Mount(height_m=1.4).pitch_deg
    -1.44
    """

    height_m: float = 1.26
    # Negative: looking slightly up, as the Udacity camera does (its vanishing row 418.6 is
    # below its principal point 389.4).
    pitch_deg: float = -1.44
    yaw_deg: float = 0.0


@dataclass(frozen=True)
class Conditions:
    """Hard conditions, each switchable.

    Attributes
    ----------
    tree_shadows, bridge_shadow : bool
        Dappled tree shadows; a bridge's shadow every 90 m.
    pavement_changes, seams : bool
        Concrete and asphalt stretches; tar seams inside the lane.
    glare : bool
        Over-exposure and a bright glow.
    worn : bool
        Holes in the paint and missing dashes.
    double_yellow : bool
        A double yellow centre line instead of a single one.
    roadside : bool
        A two-lane road with a cluttered verge instead of grass: the ego lane's right line is the
        road's edge (solid white, or bare), 0.3 m beyond it sunlit dirt in patches, dry stalks
        along the road, and a guard rail (drawn on the ground: a bright band with dark posts),
        which pass a lightness test as markings do.
    night : bool
        Night: a dark sky, the road lit by the car's low beams (falling with distance and to the
        sides) and a little ambient light, paint that shines back in the beams (retroreflective),
        vehicles ahead dark with red tail lights, and sensor noise (see :class:`NightLight`).

    Examples
    --------
    >>> Conditions(glare=True).worn
    False
    """

    tree_shadows: bool = False
    bridge_shadow: bool = False
    pavement_changes: bool = False
    seams: bool = False
    glare: bool = False
    worn: bool = False
    double_yellow: bool = False
    roadside: bool = False
    night: bool = False


@dataclass(frozen=True)
class NightLight:
    """How a night scene is lit and exposed (drawn per sequence by :meth:`random`).

    The light on the road at ``(x, z)`` (m across from the camera, m ahead) is ``ambient`` plus
    the low beams, ``min(1, (reach_m / z) ** 2)`` times a cone ``spread`` wide per metre ahead
    (plus 2 m), plus the pools of street lamps; paint returns the beams' light ``retro`` times as
    strongly as the road (the rest not); a wet road returns less of it (:attr:`albedo`) and its
    paint shines back less (:attr:`shine`).  The frame is ``exposure`` times the lit scene plus
    Gaussian noise of ``noise`` grey levels.

    Attributes
    ----------
    ambient, reach_m, spread, retro, exposure, noise : float
        As above.
    lamp_spacing_m : float
        Street lamps every this many metres along the road (0: none), ...
    lamp_rel_m : float
        ... this far across from the ego lane's centre (m, positive right), ...
    lamp_level : float
        ... each lighting a pool (about 7 m across) this bright at its centre.
    wet : bool
        A wet road: darker (``WET_ALBEDO``), its paint shining back less (``WET_RETRO``: a film
        of water mirrors the beams away), and every light (lamps, tail lights, headlights)
        mirrored in it as a long bright streak below its foot.
    oncoming : bool
        Cars come the other way in the lane left of the ego lane (drawn as road where the day's
        look has none): a pair of headlights with a glow and a wide bloom; not where the lane is
        bounded by a bare road edge.

    Examples
    --------
    >>> NightLight.random(0).retro > 1
    True
    """

    ambient: float = 0.06
    reach_m: float = 13.0
    spread: float = 0.35
    retro: float = 3.0
    exposure: float = 0.7
    noise: float = 2.5
    lamp_spacing_m: float = 0.0
    lamp_rel_m: float = 6.0
    lamp_level: float = 0.5
    wet: bool = False
    oncoming: bool = False

    @property
    def albedo(self) -> float:
        """How much of the light the ground (road, paint, verge) returns diffusely (1, or ``WET_ALBEDO`` when wet)."""
        return WET_ALBEDO if self.wet else 1.0

    @property
    def shine(self) -> float:
        """How many times as strongly as the road the paint returns the beams (``retro``, less when wet)."""
        return 1 + (self.retro - 1) * (WET_RETRO if self.wet else 1.0)

    def lit(self, amb: np.ndarray, beam: np.ndarray, paint: np.ndarray | float) -> np.ndarray:
        """Give how bright the night leaves a point of the ground, as a factor of its day colour.

        The one formula of the rendered frame and of the truth's visibility test
        (:meth:`Renderer.unlit`), so the two cannot disagree.

        Parameters
        ----------
        amb, beam : ndarray
            The light from :meth:`light`: ambient and lamps, and the beams (0-1).
        paint : ndarray or float
            How much of the point is paint (0-1): paint shines the beams back :attr:`shine` times.

        Returns
        -------
        ndarray
            ``exposure * albedo * (amb + beam * (1 + (shine - 1) * paint))``.

        Examples
        --------
        >>> n = NightLight(ambient=0.0, retro=3.0, exposure=0.5)
        >>> float(n.lit(np.float32(0.0), np.float32(1.0), 1.0)), float(n.lit(np.float32(0.0), np.float32(1.0), 0.0))
        (1.5, 0.5)
        """
        return self.exposure * self.albedo * (amb + beam * (1 + (self.shine - 1) * paint))

    @classmethod
    def random(cls, seed: int) -> NightLight:
        """Draw a night's light from a seed (its own draws: a day scene's look does not change).

        Parameters
        ----------
        seed : int
            The sequence's seed.

        Returns
        -------
        NightLight
            The light.

        Examples
        --------
        >>> NightLight.random(3) == NightLight.random(3)
        True
        """
        rng = np.random.default_rng([seed, 0x4E16])
        return cls(ambient=float(rng.uniform(0.02, 0.1)), reach_m=float(rng.uniform(10.0, 17.0)),
                   spread=float(rng.uniform(0.25, 0.45)), retro=float(rng.uniform(1.8, 4.0)),
                   exposure=float(rng.uniform(0.5, 0.9)), noise=float(rng.uniform(2.0, 7.0)),
                   lamp_spacing_m=float(rng.uniform(30.0, 50.0)) if rng.random() < 0.5 else 0.0,
                   lamp_rel_m=float(rng.choice([-1.0, 1.0]) * rng.uniform(4.0, 7.0)),
                   lamp_level=float(rng.uniform(0.3, 0.8)), wet=bool(rng.random() < 0.5),
                   oncoming=bool(rng.random() < 0.5))

    def lamp_u(self, u: np.ndarray | float) -> np.ndarray:
        """Give how far along the road a place lies from the nearest lamp's foot.

        Parameters
        ----------
        u : float or ndarray
            Distances along the road (anchored to it), m.

        Returns
        -------
        ndarray
            Signed distance to the nearest lamp, m (float32; inf without lamps).

        Examples
        --------
        >>> NightLight(lamp_spacing_m=40.0).lamp_u(np.array([20.0, 30.0])).tolist()
        [0.0, 10.0]
        """
        if self.lamp_spacing_m <= 0:
            return np.full(np.shape(u), np.inf, np.float32)
        sp = np.float32(self.lamp_spacing_m)
        return _remainder(np.array(u, np.float32), sp) - sp / 2  # a copy: the remainder is taken in place

    def light(self, x: np.ndarray, z: np.ndarray, u: np.ndarray | None = None,
              rel: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Give the light on the road at ``(x, z)`` that paint does not and does shine back (each 0-1, float32).

        Parameters
        ----------
        x, z : ndarray
            Across from the camera and ahead of it, m.
        u, rel : ndarray, optional
            Along the road (anchored to it) and across from the ego lane's centre, m: where the
            street lamps' pools fall (without them, no pools).

        Returns
        -------
        tuple of ndarray
            The ambient light and the lamps' pools, and the beams' light.

        Examples
        --------
        >>> amb, beam = NightLight().light(np.array([0.0, 0.0]), np.array([10.0, 40.0]))
        >>> float(beam[0]) > 0.9 > 0.2 > float(beam[1])
        True
        """
        z = np.maximum(np.asarray(z, np.float32), np.float32(0.5))
        fall = np.minimum(np.float32(1), (np.float32(self.reach_m) / z) ** 2)
        cone = np.exp(-((np.asarray(x, np.float32) - np.float32(0.3)) / (np.float32(self.spread) * z + 2)) ** 2)
        amb = np.full(z.shape, self.ambient, np.float32)
        if u is not None and rel is not None and self.lamp_spacing_m > 0:
            du = self.lamp_u(u)
            dr = np.asarray(rel, np.float32) - np.float32(self.lamp_rel_m)
            amb = amb + np.float32(self.lamp_level) * np.exp(-(du * du + dr * dr) / np.float32(2 * 3.5**2))
        return amb.astype(np.float32), (fall * cone).astype(np.float32)


#: Dash and gap lengths (m) a randomised road draws from: US 10/30 ft, the same in metres,
#: UK motorway 2 m/7 m, German Autobahn 6 m/12 m, city 3 m/6 m.
DASH_PATTERNS_M = ((3.0, 9.0), (3.05, 9.15), (2.0, 7.0), (6.0, 12.0), (3.0, 6.0))
#: What lies left of the ego lane: a solid yellow line, a double yellow line, a dashed white
#: line with another lane beyond it, or the road's edge with no paint.
LEFT_KINDS = ("yellow", "double-yellow", "white-dashed", "edge")


@dataclass(frozen=True)
class Marking:
    """A line painted along the road.

    Attributes
    ----------
    centre_m : float
        Its centre across the road, m from the first lane's centre (right positive).
    colour : tuple of float
        Its paint, BGR 0-255.
    dashed : bool
        Dashed (else solid).
    width_m : float
        Its width, m.

    Examples
    --------
    >>> Marking(centre_m=1.85, colour=(230.0, 230.0, 230.0), dashed=True, width_m=0.15).dashed
    True
    """

    centre_m: float
    colour: tuple[float, float, float]
    dashed: bool
    width_m: float


@dataclass(frozen=True)
class Vehicle:
    """A vehicle ahead: the rear of a box on the road, moving with the traffic.

    Attributes
    ----------
    lane : int
        Its lane: 0 the ego lane's first lane, 1 the lane to its right, -1 the lane to its left.
    z0_m : float
        Distance ahead at t = 0, m.
    closing_mps : float
        How fast it comes closer, m/s (negative: it pulls away); it wraps within 12-90 m.
    grey : float
        Its body's grey level, 0-255.

    Examples
    --------
    >>> Vehicle(lane=0, z0_m=40.0, closing_mps=1.0, grey=60.0).lane
    0
    """

    lane: int
    z0_m: float
    closing_mps: float
    grey: float

    def z_at(self, t: float) -> float:
        """Give its distance ahead at a time.

        Parameters
        ----------
        t : float
            Time, s.

        Returns
        -------
        float
            Distance ahead of the camera, m (within 12-90 m).

        Examples
        --------
        >>> Vehicle(lane=0, z0_m=40.0, closing_mps=2.0, grey=60.0).z_at(5.0)
        30.0
        """
        return 12.0 + (self.z0_m - 12.0 - self.closing_mps * t) % 78.0


@dataclass(frozen=True)
class Appearance:
    """How the road looks: surface, light, paint and clutter.  The default is the fixed look.

    Attributes
    ----------
    surface_grey, texture_contrast : float
        The surface's mean grey level (asphalt about 60-110, concrete 140-185) and its grain.
    tint : tuple of float
        Multipliers of the B, G, R channels (the light's and surface's colour).
    concrete_joints : bool
        Dark transverse joints every 4.5 m (concrete slabs).
    gain : float
        Exposure: every road pixel is multiplied by it.
    shadow_darkness : float
        What a shadow leaves of the light (0.3 deep, 0.6 soft).
    shadow_skew : float
        The sun's angle: tree shadows are sheared by this much across per metre along.
    white, yellow : tuple of float
        The paint colours, BGR.
    paint : float
        Paint coverage, 0-1 (faded paint below 1).
    marking_m : float
        Marking width, m.
    dash_m, gap_m : float
        A dashed line's dash and gap, m.
    left : str
        What bounds the ego lane on the left (one of ``LEFT_KINDS``).
    right_edge_paint : bool
        Whether the road's right edge (beyond the lane to the right) is painted.
    missing_dashes : float
        Share of dashes missing altogether.
    streaks : float
        Darkening of the tyre tracks (wheel paths), grey levels.
    tar_seams : float
        Darkening of sealed cracks ("tar snakes") and a longitudinal joint, grey levels.
    seam_rel_m : float
        Where the longitudinal joint runs, m from the lane centre.
    vehicles : tuple of Vehicle
        Vehicles ahead.

    Examples
    --------
    >>> a = Appearance.random(101)
    >>> 3.0 <= a.lane_width_m <= 3.9 and 1.1 <= a.mount.height_m <= 1.6
    True
    >>> Appearance().left
    'yellow'
    """

    surface_grey: float = 88.0
    texture_contrast: float = 7.0
    tint: tuple[float, float, float] = (0.97, 1.0, 1.02)
    concrete_joints: bool = False
    gain: float = 1.0
    shadow_darkness: float = 0.38
    shadow_skew: float = 0.0
    white: tuple[float, float, float] = (228.0, 228.0, 228.0)
    yellow: tuple[float, float, float] = (35.0, 185.0, 225.0)
    paint: float = 1.0
    marking_m: float = 0.15
    dash_m: float = 3.0
    gap_m: float = 9.0
    left: str = "yellow"
    right_edge_paint: bool = True
    missing_dashes: float = 0.0
    streaks: float = 0.0
    tar_seams: float = 0.0
    seam_rel_m: float = 0.35
    vehicles: tuple[Vehicle, ...] = ()
    lane_width_m: float | None = None
    mount: Mount = field(default_factory=Mount)

    @classmethod
    def random(cls, seed: int) -> Appearance:
        """Draw a road's look, lane width and camera mount from a seed.

        Asphalt or concrete, exposure and tint, shadow depth and sun angle, paint colour, width,
        fading and dash pattern, what bounds the lane on the left, whether the road edge is
        painted, tyre streaks, tar seams, up to two vehicles ahead; lane width 3.0-3.9 m; the
        camera 1.1-1.6 m high, pitched -4 to +1 degrees and yawed within 2 degrees.

        Parameters
        ----------
        seed : int
            The seed.

        Returns
        -------
        Appearance
            The look (with ``lane_width_m`` and ``mount`` set).
        """
        rng = np.random.default_rng([seed, 0x5EED])
        concrete = bool(rng.random() < 0.3)
        grey = float(rng.uniform(140, 185) if concrete else rng.uniform(60, 110))
        # Paint is brighter than the pavement it is on: at least 45 grey levels (on light concrete
        # as on asphalt), however faded it is drawn on top of that.
        white_level = float(rng.uniform(max(185.0, grey + 45), 250))
        dash, gap = DASH_PATTERNS_M[int(rng.integers(len(DASH_PATTERNS_M)))]
        vehicles = tuple(
            Vehicle(lane=int(rng.integers(-1, 2)), z0_m=float(rng.uniform(15, 85)),
                    closing_mps=float(rng.uniform(-3, 3)), grey=float(rng.uniform(20, 160)))
            for _ in range(int(rng.integers(0, 3))))
        return cls(
            surface_grey=grey, texture_contrast=float(rng.uniform(4, 12)),
            tint=(float(rng.uniform(0.92, 1.04)), 1.0, float(rng.uniform(0.98, 1.1))),
            concrete_joints=concrete, gain=float(rng.uniform(0.75, 1.25)),
            shadow_darkness=float(rng.uniform(0.3, 0.6)), shadow_skew=float(rng.uniform(-0.8, 0.8)),
            white=(white_level, white_level, white_level * float(rng.uniform(0.97, 1.0))),
            yellow=(float(rng.uniform(20, 80)), float(rng.uniform(160, 210)), float(rng.uniform(200, 240))),
            paint=float(rng.uniform(0.55, 1.0)), marking_m=float(rng.uniform(0.10, 0.20)),
            dash_m=dash, gap_m=gap, left=LEFT_KINDS[int(rng.choice(4, p=[0.45, 0.15, 0.25, 0.15]))],
            right_edge_paint=bool(rng.random() < 0.75), missing_dashes=float(rng.choice([0.0, 0.1, 0.25])),
            streaks=float(rng.uniform(0, 18)), tar_seams=float(rng.uniform(0, 35)),
            seam_rel_m=float(rng.uniform(-1.2, 1.2)), vehicles=vehicles,
            lane_width_m=float(rng.uniform(3.0, 3.9)),
            mount=Mount(height_m=float(rng.uniform(1.1, 1.6)), pitch_deg=float(rng.uniform(-4.0, 1.0)),
                        yaw_deg=float(rng.uniform(-2.0, 2.0))),
        )


@dataclass(frozen=True)
class Scenario:
    """A sequence: geometry that varies smoothly with time, and its conditions.

    Each geometric quantity is ``base + amp * sin(2*pi*t/period_s + phase)``.

    Attributes
    ----------
    name : str
        The scenario's name.
    speed_mps : float
        Speed, m/s.
    offset_m : tuple of float
        Car's offset from the lane centre (base, amplitude), m (positive: right of centre).
    heading : tuple of float
        Lane direction relative to the car (base, amplitude), radians.
    curvature : tuple of float
        Lane curvature (base, amplitude), 1/m.
    curvature_rate : tuple of float
        Change of curvature with distance (base, amplitude), 1/m^2.
    width_m : tuple of float
        Lane width (base, amplitude), m.
    period_s : float
        Period of the variation, s.
    conditions : Conditions
        The hard conditions.
    description : str
        One line for ``lanefinder synth --list``.
    vertical_curvature : tuple of float
        The road's vertical curvature (base, amplitude), 1/m: positive a crest (the road falls
        away ahead), negative a sag (it rises).  The car sits on the road and pitches with it, so
        the road ``z`` m ahead lies ``vertical_curvature * z**2 / 2`` below the car's plane; a
        crest hides the road beyond it.
    manoeuvres : tuple of (float, float, float)
        Moves across the road, each ``(start_s, duration_s, lateral_shift_m)``: the car's offset
        from its first lane's centre changes by ``lateral_shift_m`` (positive: to the right) over
        ``duration_s`` from ``start_s``, along a raised cosine, and the car heads along its path
        (see :func:`manoeuvre_shift`).  Added to ``offset_m``.

    Examples
    --------
    >>> SCENARIOS["sharp-curve"].speed_mps
    12.0
    >>> SCENARIOS["lane-change"].manoeuvres[0]
    (2.0, 3.5, 3.7)
    """

    name: str
    speed_mps: float = 25.0
    offset_m: tuple[float, float] = (0.1, 0.25)
    heading: tuple[float, float] = (0.0, 0.004)
    curvature: tuple[float, float] = (0.0, 0.0)
    curvature_rate: tuple[float, float] = (0.0, 0.0)
    width_m: tuple[float, float] = (3.7, 0.1)
    period_s: float = 8.0
    conditions: Conditions = field(default_factory=Conditions)
    description: str = ""
    manoeuvres: tuple[tuple[float, float, float], ...] = ()
    vertical_curvature: tuple[float, float] = (0.0, 0.0)

    @property
    def duration_s(self) -> float:
        """Give the time the manoeuvres need, with 1.5 s after the last, s (0 without manoeuvres)."""
        return max((t0 + d + 1.5 for t0, d, _ in self.manoeuvres), default=0.0)


def manoeuvre_shift(manoeuvres: tuple[tuple[float, float, float], ...], t: float) -> tuple[float, float]:
    """Give the lateral shift of the car from its manoeuvres at a time, and its rate.

    Each manoeuvre ``(start_s, duration_s, shift_m)`` adds shift_m * (1 - cos(pi * u)) / 2,
    u = (t - start_s) / duration_s clipped to 0..1.

    Parameters
    ----------
    manoeuvres : tuple of (float, float, float)
        ``(start_s, duration_s, lateral_shift_m)`` each.
    t : float
        Time, s.

    Returns
    -------
    tuple of float
        The shift, m (positive: to the right), and its rate, m/s.

    Examples
    --------
    >>> [round(v, 3) for v in manoeuvre_shift(((1.0, 2.0, 3.7),), 2.0)]
    [1.85, 2.906]
    >>> manoeuvre_shift(((1.0, 2.0, 3.7),), 5.0)
    (3.7, 0.0)
    """
    shift = rate = 0.0
    for t0, dur, amount in manoeuvres:
        u = min(max((t - t0) / dur, 0.0), 1.0)
        shift += amount * (1 - math.cos(math.pi * u)) / 2
        if 0.0 < u < 1.0:
            rate += amount * math.pi / (2 * dur) * math.sin(math.pi * u)
    return shift, rate


SCENARIOS: dict[str, Scenario] = {s.name: s for s in [
    Scenario("straight", description="straight highway, solid yellow left, dashed white right"),
    Scenario("curve", curvature=(1 / 900, 1 / 3000), description="highway curve, R 700-1300 m"),
    Scenario("shadows", curvature=(1 / 1500, 0.0),
             conditions=Conditions(tree_shadows=True, bridge_shadow=True), description="tree and bridge shadows"),
    Scenario("pavement", curvature=(-1 / 1200, 0.0),
             conditions=Conditions(pavement_changes=True, seams=True),
             description="pavement colour changes and seams inside the lane"),
    Scenario("glare", conditions=Conditions(glare=True), description="glare and over-exposure"),
    Scenario("worn", curvature=(1 / 2000, 0.0), conditions=Conditions(worn=True),
             description="worn and missing markings"),
    Scenario("double-yellow", curvature=(-1 / 1000, 0.0), conditions=Conditions(double_yellow=True),
             description="double yellow centre line"),
    Scenario("curve-entry", curvature=(1 / 500, 1 / 500), heading=(0.0, 0.006), offset_m=(0.1, 0.3),
             period_s=5.0, conditions=Conditions(tree_shadows=True),
             description="curves (R down to 250 m) beginning and ending in tree shadow, with lateral drift"),
    Scenario("sharp-curve", speed_mps=12.0, curvature=(1 / 90, 1 / 400), curvature_rate=(0.0, 2e-4),
             offset_m=(0.0, 0.2), width_m=(3.5, 0.1), period_s=6.0, description="sharp curves, R 70-130 m"),
    # Lane events (events_gt.jsonl): wheels 1.8 m apart; with a 3.7 m lane a wheel reaches a line
    # at an offset of 0.95 m.
    Scenario("lane-change", offset_m=(0.0, 0.03), heading=(0.0, 0.002), curvature=(1 / 1000, 1 / 4000),
             width_m=(3.7, 0.03), manoeuvres=((2.0, 3.5, 3.7), (8.5, 3.5, -3.7)),
             description="a change to the right lane and back, over 3.5 s each, on a gentle curve (340 frames)"),
    Scenario("drift", offset_m=(0.0, 0.03), heading=(0.0, 0.002), curvature=(-1 / 1500, 0.0), width_m=(3.7, 0.03),
             manoeuvres=((0.5, 2.5, -1.15), (4.0, 2.0, 1.15), (6.0, 2.0, 0.7), (8.5, 2.0, -0.7),
                         (10.5, 2.5, 1.2), (14.0, 2.0, -1.2), (16.0, 2.0, -0.7), (18.5, 2.0, 0.7)),
             description="drifts 0.18/0.30 m over the left/right line and back; near misses 0.23-0.28 m inside "
                         "(550 frames)"),
    # The flat-road assumption of the bird's-eye view, broken: a crest (vertical radius 900 m) hides
    # the road beyond about 50 m, a sag lifts it; the lines converge or splay in the view.
    Scenario("hills", speed_mps=16.0, curvature=(0.0, 1 / 450), vertical_curvature=(0.0, 1 / 900), period_s=6.0,
             offset_m=(0.1, 0.2), conditions=Conditions(roadside=True),
             description="crests and sags (vertical radius 900 m) on a winding two-lane road (R 450 m), a cluttered "
                         "verge"),
    # Curvature that changes along the view, as on real winding roads (a bend tightening or opening,
    # an S-bend): the lines are cubics, which a second-order fit in the view can only approach.
    Scenario("winding", speed_mps=15.0, curvature=(0.0, 1 / 250), curvature_rate=(0.0, 1.5e-4), offset_m=(0.05, 0.15),
             width_m=(3.5, 0.1), period_s=7.0,
             description="winding road: curvature changing along the view (S-bends, bends tightening and "
                         "opening), R down to about 130 m within 40 m ahead"),
    Scenario("night", curvature=(1 / 1200, 1 / 3000), conditions=Conditions(night=True),
             description="night: the car's low beams and a little ambient light, paint shining back in the beams, "
                         "tail lights, sensor noise"),
]}


@dataclass(frozen=True)
class FrameTruth:
    """Ground truth of one frame (see the module docstring for where it is measured).

    Attributes
    ----------
    frame : int
        Frame index.
    time_s : float
        Time, s.
    curvature_per_m : float
        Signed curvature of the lane centre, 1/m.
    radius_m : float or None
        Radius, m; None on a straight road.
    offset_m : float
        Car's offset from the lane centre, m (positive: right of centre).
    width_m : float
        Lane width, m.
    h_samples : list of int
        The TuSimple rows, pixels.
    left_x, right_x : list of float
        Each line's x in the distorted frame at those rows, pixels; -2 where absent.  The
        truth runs as far as the marking is at least 1.5 px wide (see ``Renderer.visible_m``).
    row_distance_m : list of float
        Distance ahead of the camera of the road seen at each row's centre, m; -1 above the road.
    lateral : dict
        For each distance in ``LATERAL_AT_M`` (keys ``"6"``, ``"20"``): the row ``y`` of the
        road that far ahead, ``m_per_px`` across the road there, and both lines' ``x`` (pixels).

    Examples
    --------
    >>> t = FrameTruth(frame=3, time_s=0.12, curvature_per_m=0.0, radius_m=None, offset_m=0.1,
    ...                width_m=3.7, h_samples=[700], left_x=[300.0], right_x=[-2.0])
    >>> t.to_json()["raw_file"], t.to_json()["lanes"]
    ('frame/000003', [[300.0]])
    """

    frame: int
    time_s: float
    curvature_per_m: float
    radius_m: float | None
    offset_m: float
    width_m: float
    h_samples: list[int]
    left_x: list[float]
    right_x: list[float]
    row_distance_m: list[float] = field(default_factory=list)
    lateral: dict = field(default_factory=dict)

    def to_json(self) -> dict:
        """Give the row of ``gt.jsonl``: the fields, a TuSimple ``raw_file`` key and ``lanes``.

        Returns
        -------
        dict
            JSON-ready values.
        """
        d = asdict(self)
        d["raw_file"] = f"frame/{self.frame:06d}"
        d["lanes"] = [lane for lane in (self.left_x, self.right_x) if any(v >= 0 for v in lane)]
        return d


def level_to_camera(pitch_deg: float, yaw_deg: float = 0.0) -> np.ndarray:
    """Give the rotation from the car's level frame to the camera frame for a pitch and a yaw.

    The camera is turned by the yaw (about the level frame's vertical), then pitched.

    Parameters
    ----------
    pitch_deg : float
        Pitch down, degrees.
    yaw_deg : float, optional
        Yaw to the right, degrees.

    Returns
    -------
    (3, 3) ndarray
        R with camera = R @ level (X right, Y down, Z forward in both).

    Examples
    --------
    >>> level_to_camera(0.0).tolist()
    [[1.0, 0.0, 0.0], [0.0, 1.0, -0.0], [0.0, 0.0, 1.0]]
    """
    p, q = math.radians(pitch_deg), math.radians(yaw_deg)
    pitch = np.array([[1, 0, 0], [0, math.cos(p), -math.sin(p)], [0, math.sin(p), math.cos(p)]])
    if q == 0.0:
        return pitch
    yaw = np.array([[math.cos(q), 0, -math.sin(q)], [0, 1, 0], [math.sin(q), 0, math.cos(q)]])
    return pitch @ yaw


_GroundSamples = tuple[int, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]
_GROUND_CACHE: dict[bytes, _GroundSamples] = {}
_GROUND_CACHE_SIZE = 2  # about 50 MB an entry at 720p; sequences of one camera and mount share one
#: The undistorted samples of the last lens (about 60 MB at 720p): sequences of one lens on other mounts share them.
_UNDISTORTED: dict[bytes, np.ndarray] = {}


#: Samples per pass of the remainders below (float64 work arrays of 2 MB).
_REMAINDER_CHUNK = 1 << 18


def _exact_remainders(a: np.ndarray, period: float) -> Iterator[tuple[slice, np.ndarray]]:
    """Give the remainders of a C-contiguous float32 array by a period (taken as a float32), exactly, pass by pass.

    Each pass gives its slice of the flattened array and the remainders there (float64).

    Worked in float64 (about four times as fast as float32's ``fmod``, a loop in the C library):
    the quotient's floor ``q`` may be one off where the division rounds, and is then corrected;
    ``q * period`` (a 24-bit period times a whole number under 2**29) and ``x - q * period``
    (both on the grid of ``x``'s last bit, the result under ``period``) are exact.  So the
    remainder is the exact one, as ``fmod`` and NumPy's remainder give it (a float32 number).
    The rare values 2**29 periods or more from zero (near the horizon of a sharp curve) are
    left to NumPy's remainder.
    """
    if a.dtype != np.float32 or not a.flags.c_contiguous:
        raise TypeError("the renderer's remainders take a C-contiguous float32 array")
    flat, period = a.reshape(-1), float(np.float32(period))
    for i in range(0, flat.size, _REMAINDER_CHUNK):
        part = flat[i:i + _REMAINDER_CHUNK]
        x = part.astype(np.float64)
        q = x / period
        np.floor(q, out=q)
        q *= period
        x -= q
        x[x < 0] += period
        x[x >= period] -= period
        far = np.abs(part) >= np.float32(2.0**29 * period)
        if far.any():
            x[far] = np.remainder(part[far], np.float32(period))
        yield slice(i, i + _REMAINDER_CHUNK), x


def _remainder(a: np.ndarray, b: float) -> np.ndarray:
    """Give ``a % b`` for ``b > 0`` in about a quarter of NumPy's time, in place on ``a``.

    ``a`` is a C-contiguous float32 array; ``b`` a Python float or a float32 (taken as a
    float32, as NumPy's remainder of a float32 array takes it).
    The same floats as NumPy's remainder, bit for bit (``tests/test_synth.py`` checks it).
    """
    flat = a.reshape(-1)
    for part, r in _exact_remainders(a, b):
        flat[part] = r
    return a


def _remainder_below(u: np.ndarray, period: float, limit: float) -> np.ndarray:
    """Tell where ``np.fmod(u, period) < limit`` for float32 ``u >= 0``, bit for bit, about four times as fast.

    (NumPy compares a float32 array with a Python float in float32: so does this.)
    """
    out = np.empty(u.shape, bool)
    flat_out, lim = out.reshape(-1), float(np.float32(limit))
    for part, r in _exact_remainders(u, period):
        flat_out[part] = r < lim
    return out


def _ground_samples(camera: CameraModel, rot: np.ndarray, height_m: float, s: int,
                    hills: bool = False) -> _GroundSamples:
    """Give where every sub-pixel sample of the distorted frame meets the road (cached per camera and mount).

    Returns the first row band holding road (``r0``, in sub-pixel rows, whole output rows), the
    road mask below it, the road's lateral X and distance Z there (m, float32) on a level road,
    the sky frame, the sky of the band, and the samples' rays (level-frame directions, (3, ...)
    float32).  With ``hills`` (crests and sags) the band starts ``HILL_RAY_SLOPE`` above the
    level horizon (a rising road shows there) and only the rays are given (the mask, X and Z
    are empty: the road is met per frame); without, the rays are empty.  This costs about a
    second at 720p, so sequences of the same camera and mount reuse it (the arrays are
    read-only), and sequences of the same lens on another mount reuse its undistorted samples.
    """
    w, h = camera.image_size
    key = b"|".join([np.asarray(camera.camera_matrix, np.float64).tobytes(),
                     np.asarray(camera.dist_coeffs, np.float64).tobytes(), np.asarray(rot, np.float64).tobytes(),
                     np.float64(height_m).tobytes(), np.int64([w, h, s, hills]).tobytes()])
    if key in _GROUND_CACHE:
        return _GROUND_CACHE[key]
    lens = b"|".join([np.asarray(camera.camera_matrix, np.float64).tobytes(),
                      np.asarray(camera.dist_coeffs, np.float64).tobytes(), np.int64([w, h, s]).tobytes()])
    norm = _UNDISTORTED.get(lens)
    if norm is None:
        xs = (np.arange(w * s) + 0.5) / s - 0.5
        ys = (np.arange(h * s) + 0.5) / s - 0.5
        gx, gy = np.meshgrid(xs, ys)
        pts = np.column_stack([gx.ravel(), gy.ravel()]).reshape(-1, 1, 2)
        norm = cv2.undistortPoints(pts, camera.camera_matrix, camera.dist_coeffs).reshape(-1, 2)
        norm.flags.writeable = False
        _UNDISTORTED.clear()
        _UNDISTORTED[lens] = norm
    rays = np.column_stack([norm, np.ones(len(norm))]) @ rot  # level-frame directions (R^T d)
    dy = rays[:, 1]
    ground = dy > 1e-4
    t = np.where(ground, height_m / np.where(ground, dy, 1), 0.0)
    grid = (h * s, w * s)
    ground = ground.reshape(grid)
    # Only the rows that hold road are shaded per frame; the sky is drawn once.
    band = (rays[:, 1] > -HILL_RAY_SLOPE * np.hypot(rays[:, 0], rays[:, 2])).reshape(grid) if hills else ground
    rows_with_road = np.flatnonzero(band.any(axis=1))
    r0 = int(rows_with_road[0]) if rows_with_road.size else grid[0]
    r0 -= r0 % s  # whole output rows
    length = np.sqrt(rays[:, 0] * rays[:, 0] + rays[:, 1] * rays[:, 1] + rays[:, 2] * rays[:, 2])  # np.linalg.norm's
    up = np.clip(-(dy / length).reshape(grid) * 4, 0, 1).astype(np.float32)
    sky = np.stack([235 - 60 * up, 200 - 40 * up, 170 - 30 * up], -1)
    sky_full = cv2.resize(sky, (w, h), interpolation=cv2.INTER_AREA)
    if hills:  # the road is met frame by frame (Renderer.meet_road): only the rays are kept
        none = np.zeros((0, 0), np.float32)
        road, X, Z = none.astype(bool), none, none
        ray_band = rays.reshape(grid + (3,))[r0:].transpose(2, 0, 1).astype(np.float32)
    else:
        road = ground[r0:].copy()
        X = (t * rays[:, 0]).reshape(grid)[r0:].astype(np.float32)
        Z = (t * rays[:, 2]).reshape(grid)[r0:].astype(np.float32)
        ray_band = np.zeros((3, 0, 0), np.float32)
    out = (r0, road, X, Z, sky_full, sky[r0:].copy(), ray_band)
    for a in out[1:]:
        a.flags.writeable = False
    while len(_GROUND_CACHE) >= _GROUND_CACHE_SIZE:
        _GROUND_CACHE.pop(next(iter(_GROUND_CACHE)))
    _GROUND_CACHE[key] = out
    return out


class Renderer:
    """Render the frames of a scenario, and their ground truth, for one camera and mount.

    Parameters
    ----------
    camera : CameraModel
        The lens, at the frame size to render.
    mount : Mount
        Where the camera sits.
    scenario : Scenario
        What the road does.
    seed : int, optional
        Seed of the textures, wear and dash phase.
    z_near, z_far : float, optional
        The ground truth's reference distance and the view's far end, m.
    supersample : int, optional
        Samples per pixel along each axis.
    appearance : Appearance, optional
        The road's look (default: the fixed look); its ``mount`` and ``lane_width_m`` are not
        used here (see :func:`write_sequence`).
    start_s : float, optional
        Where in the road's cycle (``scenario.period_s``) the first frame lies, s: the
        geometry at time t is the scenario's at ``t + start_s`` (its manoeuvres keep their times).

    Examples
    --------
    >>> from lanefinder.camera import CameraModel
    >>> r = Renderer(CameraModel.ideal((320, 180)), Mount(), SCENARIOS["straight"])
    >>> frame, truth = next(r.frames(1))
    >>> frame.shape, round(truth.width_m, 3)
    ((180, 320, 3), 3.739)
    """

    def __init__(self, camera: CameraModel, mount: Mount, scenario: Scenario, seed: int = 0,
                 z_near: float = 6.0, z_far: float = 35.0, supersample: int = 2,
                 appearance: Appearance | None = None, start_s: float = 0.0):
        self.camera, self.mount, self.sc = camera, mount, scenario
        if not math.isfinite(start_s):
            raise LaneFinderError(f"start_s must be a finite number of seconds, not {start_s}")
        self.start_s = float(start_s)
        self.look = appearance or Appearance()
        self.z_near, self.z_far = z_near, z_far
        self.rot = level_to_camera(mount.pitch_deg, mount.yaw_deg)
        w, h = camera.image_size
        rng = np.random.default_rng(seed)
        self.texture = cv2.GaussianBlur(rng.random((256, 256)).astype(np.float32), (0, 0), 1.5)
        self.texture = (self.texture - self.texture.mean()) / (self.texture.std() + 1e-6)
        self.blobs = cv2.GaussianBlur(rng.random((128, 128)).astype(np.float32), (0, 0), 6)
        self.blobs = (self.blobs - self.blobs.mean()) / (self.blobs.std() + 1e-6)
        self.wear = rng.random(4096).astype(np.float32)
        self.dash_phase = float(rng.uniform(0, DASH_M + GAP_M))
        if self.look.tar_seams > 0:
            cracks = cv2.GaussianBlur(rng.random((256, 256)).astype(np.float32), (0, 0), 5)
            cracks = (cracks - cracks.mean()) / (cracks.std() + 1e-6)
            self.cracks = (np.abs(cracks) < 0.06).astype(np.float32)  # thin meandering contours
        if not scenario.speed_mps >= 0:
            raise LaneFinderError(f"a scenario's speed must be 0 m/s or more, not {scenario.speed_mps}")
        self.hills = any(v != 0 for v in scenario.vertical_curvature)
        self.seed = seed
        self.night = ((NightLight.random(seed) if appearance is not None else NightLight())
                      if scenario.conditions.night else None)
        self.r0, self.ground, self.X, self.Z, self.sky_full, self.sky_band, self.rays = _ground_samples(
            camera, self.rot, mount.height_m, supersample, self.hills)
        self.size, self.s = (w, h), supersample
        self._level_sky_rows: int | None = None
        if self.r0 // supersample >= h:
            raise LaneFinderError(f"no road is in view: this camera ({w}x{h}, focal length "
                                  f"{camera.camera_matrix[0, 0]:g} px, principal point at row "
                                  f"{camera.camera_matrix[1, 2]:g}) at {mount.height_m:g} m pitched "
                                  f"{mount.pitch_deg:g} degrees sees no road below the horizon")
        # On a level road every frame meets the road at the same distances: zero where there is none.
        self.Zc = None if self.hills else np.where(self.ground, self.Z, 0).astype(np.float32)
        if self.Zc is not None:
            self.Zc.flags.writeable = False  # shared by every frame

    @property
    def oncoming_lane(self) -> bool:
        """Whether cars come the other way left of the ego lane (``oncoming``, not beyond a bare edge)."""
        return self.night is not None and self.night.oncoming and self.look.left != "edge"

    # -- geometry ---------------------------------------------------------------------------
    def geometry(self, t: float) -> dict:
        """Give the road's geometry at a time.

        Parameters
        ----------
        t : float
            Time, s.

        Returns
        -------
        dict
            ``offset`` (m), ``heading`` (rad), ``curvature`` (1/m), ``curvature_rate``
            (1/m^2), ``width`` (m), ``travelled`` (m), ``vertical_curvature`` (1/m).
        """
        sc = self.sc
        ph = 2 * math.pi * (t + self.start_s) / sc.period_s

        def val(base_amp: tuple[float, float], phase: float = 0.0) -> float:
            return base_amp[0] + base_amp[1] * math.sin(ph + phase)

        g = {
            "offset": val(sc.offset_m), "heading": val(sc.heading, 1.3), "curvature": val(sc.curvature, 0.7),
            "curvature_rate": val(sc.curvature_rate, 2.1), "width": val(sc.width_m, 0.4),
            "travelled": sc.speed_mps * t, "vertical_curvature": val(sc.vertical_curvature, 2.7),
        }
        if sc.manoeuvres:
            # Moving sideways at v the car heads v/speed off the lane, so the lane turns the other way.
            shift, rate = manoeuvre_shift(sc.manoeuvres, t)
            g["offset"] += shift
            g["heading"] -= rate / sc.speed_mps
        return g

    @staticmethod
    def ego_lane(g: dict) -> int:
        """Give the lane that holds the camera: 0 the first lane, 1 the lane to its right.

        Parameters
        ----------
        g : dict
            From :meth:`geometry`.

        Returns
        -------
        int
            The lane's index.
        """
        return 1 if g["offset"] >= g["width"] / 2 else 0

    @classmethod
    def ego_geometry(cls, g: dict) -> dict:
        """Give the geometry relative to the ego lane (:meth:`ego_lane`): its offset is the car's from that lane.

        Parameters
        ----------
        g : dict
            From :meth:`geometry` (relative to the first lane).

        Returns
        -------
        dict
            The same keys; ``g`` itself when the car is in its first lane.
        """
        k = cls.ego_lane(g)
        return g if k == 0 else {**g, "offset": g["offset"] - k * g["width"]}

    @staticmethod
    def centre(g: dict, z: np.ndarray | float) -> np.ndarray | float:
        """Give the lane centre's lateral position at distances ahead.

        Parameters
        ----------
        g : dict
            From :meth:`geometry`.
        z : float or ndarray
            Distance ahead, m.

        Returns
        -------
        float or ndarray
            Lateral position, m (right positive).
        """
        x = -g["offset"] + g["heading"] * z
        # A zero term adds nothing: skipped, it costs nothing (a frame has millions of samples).
        if g["curvature"]:
            x = x + g["curvature"] / 2 * z**2
        if g["curvature_rate"]:
            x = x + g["curvature_rate"] / 6 * z**3
        return x

    def road_y(self, g: dict, z: np.ndarray | float) -> np.ndarray | float:
        """Give how far below the camera the road lies at distances ahead (the level frame's y).

        Parameters
        ----------
        g : dict
            From :meth:`geometry`.
        z : float or ndarray
            Distance ahead, m.

        Returns
        -------
        float or ndarray
            Depth below the camera, m: its height on a level road, more beyond a crest.
        """
        return self.mount.height_m + g.get("vertical_curvature", 0.0) / 2 * z**2

    def meet_road(self, g: dict, rays: np.ndarray) -> np.ndarray:
        """Give where rays from the camera first meet the road, as multiples of each ray (nan: never).

        The road ``z`` ahead lies ``road_y`` below the camera: ``t * ry = H + k * (t * rz)**2 / 2``,
        whose smaller positive root is ``2H / (ry + sqrt(ry**2 - 2 k H rz**2))``.  Rays past a
        crest, and points farther than ``HILL_VIEW_M``, give nan.

        Parameters
        ----------
        g : dict
            From :meth:`geometry`.
        rays : (3, ...) ndarray
            Level-frame directions (x right, y down, z ahead).

        Returns
        -------
        ndarray
            The multiple t (the point is ``t * ray``), the shape of one component.
        """
        _, ry, rz = rays
        k, height = g.get("vertical_curvature", 0.0), self.mount.height_m
        with np.errstate(invalid="ignore", divide="ignore"):
            den = ry + np.sqrt(ry * ry - 2 * k * height * rz * rz)
            t = 2 * height / den
        return np.where((den > 0) & (t * rz > 0) & (t * rz <= HILL_VIEW_M), t, np.nan)

    def truth(self, index: int, t: float, g: dict) -> FrameTruth:
        """Give the ground truth of a frame.

        Parameters
        ----------
        index : int
            Frame index.
        t : float
            Time, s.
        g : dict
            From :meth:`geometry` at ``t``.

        Returns
        -------
        FrameTruth
            Curvature, radius, offset and width at ``z_near``; line x at the TuSimple rows; all of
            the ego lane (the lane that holds the camera).
        """
        road, g = g, self.ego_geometry(g)
        z0 = self.z_near
        d1 = g["heading"] + g["curvature"] * z0 + g["curvature_rate"] / 2 * z0**2
        d2 = g["curvature"] + g["curvature_rate"] * z0
        k = d2 / (1 + d1 * d1) ** 1.5
        rows = tusimple_rows(self.size[1])
        lateral = {}
        for z in LATERAL_AT_M:
            y, xs = self._line_image_at(g, z)
            lateral[f"{z:g}"] = {"y": round(y, 2), "m_per_px": round(z / float(self.camera.camera_matrix[0, 0]), 6),
                                 "x": [round(x, 2) for x in xs]}
        left = self._line_rows(g, -0.5, rows, self.ego_marking(road, -0.5), t)
        right = self._line_rows(g, 0.5, rows, self.ego_marking(road, 0.5), t)
        if self.look.vehicles:
            polys = [poly.astype(np.float32) for _, poly in self.vehicles(t, road)]
            left, right = self._unoccluded(polys, rows, left), self._unoccluded(polys, rows, right)
        return FrameTruth(index, round(t, 4), float(k), float(1 / abs(k)) if abs(k) > 1e-9 else None,
                          float(-self.centre(g, z0)), float(g["width"]), rows, left, right,
                          self._row_distances(rows, g), lateral)

    @staticmethod
    def _unoccluded(polys: list[np.ndarray], rows: list[int], xs: list[float]) -> list[float]:
        """Drop the truth points hidden behind a vehicle's polygon (-2 there)."""
        return [x if x < 0 or not any(cv2.pointPolygonTest(p, (x, float(r)), False) >= 0 for p in polys) else -2.0
                for x, r in zip(xs, rows, strict=True)]

    @property
    def visible_m(self) -> float:
        """Give the farthest distance at which a marking is at least 1.5 px wide, m (at most 150 m)."""
        return float(min(150.0, self.camera.camera_matrix[0, 0] * self.look.marking_m / 1.5))

    def _row_distances(self, rows: list[int], g: dict) -> list[float]:
        """Give the distance ahead (m) of the road seen at each row's centre column; -1 above the road."""
        w = self.size[0]
        pts = np.array([[(w - 1) / 2, r] for r in rows], np.float64).reshape(-1, 1, 2)
        norm = cv2.undistortPoints(pts, self.camera.camera_matrix, self.camera.dist_coeffs).reshape(-1, 2)
        rays = np.column_stack([norm, np.ones(len(norm))]) @ self.rot
        if self.hills:
            z = self.meet_road(g, rays.T) * rays[:, 2]
        else:
            with np.errstate(divide="ignore", invalid="ignore"):
                z = np.where(rays[:, 1] > 1e-6, self.mount.height_m / rays[:, 1] * rays[:, 2], np.nan)
        return [round(float(v), 3) if np.isfinite(v) else -1.0 for v in z]

    def _line_image_at(self, g: dict, z: float) -> tuple[float, list[float]]:
        """Give the row of the road ``z`` m ahead and both lines' x there, distorted frame pixels."""
        xs = [self.centre(g, z) - 0.5 * g["width"], self.centre(g, z) + 0.5 * g["width"]]
        pts = np.array([[x, self.road_y(g, z), z] for x in xs])
        rvec, _ = cv2.Rodrigues(self.rot)
        img, _ = cv2.projectPoints(pts, rvec, np.zeros(3), self.camera.camera_matrix, self.camera.dist_coeffs)
        img = img.reshape(-1, 2)
        return float(img[:, 1].mean()), [float(v) for v in img[:, 0]]

    def _line_rows(self, g: dict, side: float, rows: list[int], marking: Marking | None, t: float) -> list[float]:
        """Give the x of a line (side -0.5 left, +0.5 right) in the distorted frame at ``rows``; -2 where absent.

        The truth runs as far as the marking is visible: to the farthest paint in the frame
        (gaps between dashes and worn patches nearer than that are labelled through, as
        TuSimple's annotators do), and no farther than :attr:`visible_m`; paint that glare
        washes out (:meth:`washed_out`) is not visible.  A line with no paint
        in the frame (``marking`` None, or every dash in view missing) has no truth.
        """
        if marking is None:
            return [-2.0] * len(rows)
        z = np.geomspace(0.5, self.visible_m, 1500)
        x = self.centre(g, z) + side * g["width"]
        pts = np.column_stack([x, np.broadcast_to(self.road_y(g, z), z.shape), z])
        cam = pts @ self.rot.T
        w, h = self.size
        k = self.camera.camera_matrix
        und = (cam @ k.T)[:, :2] / (cam @ k.T)[:, 2:]
        # Only points whose pinhole image is (nearly) in view: the lens polynomial is not
        # monotonic far outside the calibrated field.
        ok = (cam[:, 2] > 0) & (und[:, 0] > -0.1 * w) & (und[:, 0] < 1.1 * w) & (und[:, 1] > -0.1 * h) & (
            und[:, 1] < 1.1 * h)
        if self.hills:  # beyond a crest the road sinks behind it: a point shows only above all nearer road
            level = pts[:, 1] / z  # the slope below the level horizon
            ok &= level <= np.minimum.accumulate(level) + 1e-12
        seen = ok & (und[:, 0] >= 0) & (und[:, 0] < w) & (und[:, 1] >= 0) & (und[:, 1] < h)
        painted = seen & (self.paint_along(z + g["travelled"], marking.dashed) > 0)
        painted &= ~self.washed_out(t, und[:, 0], und[:, 1], marking.colour)
        if self.night is not None:
            painted &= ~self.unlit(x, z, marking.colour, self.paint_along(z + g["travelled"], marking.dashed),
                                   z + g["travelled"], x - self.centre(g, z))
        if not painted.any():
            return [-2.0] * len(rows)
        ok &= z <= z[painted].max()
        if ok.sum() < 2:
            return [-2.0] * len(rows)
        rvec, _ = cv2.Rodrigues(self.rot)
        img, _ = cv2.projectPoints(pts[ok], rvec, np.zeros(3), k, self.camera.dist_coeffs)
        img = img.reshape(-1, 2)[::-1]  # far to near: rows increase
        fy, fx = img[:, 1], img[:, 0]
        inside = (fx >= 0) & (fx < w) & (fy >= 0) & (fy < h)
        out = []
        for r in rows:
            if fy.size < 2 or r < fy[0] or r > fy[-1]:
                out.append(-2.0)
                continue
            i = int(np.searchsorted(fy, r))
            i = min(max(i, 1), fy.size - 1)
            if not (inside[i] and inside[i - 1]):
                out.append(-2.0)
                continue
            a = (r - fy[i - 1]) / (fy[i] - fy[i - 1])
            out.append(round(float(fx[i - 1] + a * (fx[i] - fx[i - 1])), 2))
        return out

    def paint_along(self, u: np.ndarray, dashed: bool) -> np.ndarray:
        """Give how much of a line's paint is there along the road: dashes, missing dashes, wear.

        Parameters
        ----------
        u : ndarray
            Distances along the road (anchored to it), m.
        dashed : bool
            A dashed line (else solid).

        Returns
        -------
        ndarray
            Paint factor at each distance, 0 (none) to 1.
        """
        look, f = self.look, np.ones(u.shape, np.float32)
        if dashed:
            period = look.dash_m + look.gap_m
            f = f * (((u + self.dash_phase) % period) < look.dash_m)
            if look.missing_dashes > 0:
                gone = self.wear[((u + self.dash_phase) / period).astype(np.int64) % self.wear.size]
                f = f * (gone >= look.missing_dashes)
        if self.sc.conditions.worn:
            holes = self.wear[(u * 2).astype(np.int64) % self.wear.size] < 0.25
            f = f * np.where(holes, 0.0, 0.55)
            if dashed:
                f = f * ~(self.wear[(u / (DASH_M + GAP_M)).astype(np.int64) % self.wear.size] < 0.2)
        return f

    def road_markings(self, width: float) -> list[Marking]:
        """Give the lines painted across the road, as the renderer paints them.

        Parameters
        ----------
        width : float
            The lane width, m.

        Returns
        -------
        list of Marking
            Each painted line; ``centre_m`` is across the road from the first lane's centre.
        """
        look, half = self.look, width / 2
        if self.sc.conditions.double_yellow or look.left == "double-yellow":
            out = [Marking(-half - 0.1, look.yellow, False, 0.1), Marking(-half + 0.1, look.yellow, False, 0.1)]
        elif look.left == "white-dashed":
            out = [Marking(-half, look.white, True, look.marking_m), Marking(-1.5 * width, look.white, False,
                                                                               look.marking_m)]
        elif look.left == "yellow":
            out = [Marking(-half, look.yellow, False, look.marking_m)]
        else:  # a bare edge
            out = []
        if self.sc.conditions.roadside:  # a two-lane road: the ego lane's right line is the road's edge
            return out + ([Marking(half, look.white, False, look.marking_m)] if look.right_edge_paint else [])
        out.append(Marking(half, look.white, True, look.marking_m))
        if look.right_edge_paint:
            out.append(Marking(1.5 * width, look.white, False, look.marking_m))
        return out

    def ego_marking(self, g: dict, side: float) -> Marking | None:
        """Give the marking on one side of the ego lane (:meth:`ego_lane`), or None where it is bare.

        Parameters
        ----------
        g : dict
            From :meth:`geometry` (relative to the first lane).
        side : float
            -0.5 for the left line, +0.5 for the right.

        Returns
        -------
        Marking or None
            The marking there (of a double line, the first).
        """
        at = (side + self.ego_lane(g)) * g["width"]
        return next((m for m in self.road_markings(g["width"]) if abs(m.centre_m - at) <= 0.15), None)

    def glow(self, t: float, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Give the glare's glow at frame pixels (the sun low ahead), 0-1.

        Parameters
        ----------
        t : float
            Time, s.
        x, y : ndarray
            Frame pixels.

        Returns
        -------
        ndarray
            The glow (the frame is ``GLARE_GAIN`` times brighter plus ``GLARE_GLOW`` times this).
        """
        w, h = self.size
        cx, cy = w * (0.55 + 0.1 * math.sin(t)), h * 0.62
        return np.exp(-(((x - cx) / (0.4 * w)) ** 2 + ((y - cy) / (0.25 * h)) ** 2))

    def washed_out(self, t: float, x: np.ndarray, y: np.ndarray, paint: tuple[float, float, float]) -> np.ndarray:
        """Tell where glare leaves a marking less than ``MIN_VISIBLE_CONTRAST`` from the road in every channel.

        Parameters
        ----------
        t : float
            Time, s.
        x, y : ndarray
            Frame pixels.
        paint : tuple of float
            The paint's colour, BGR 0-255.

        Returns
        -------
        ndarray of bool
            True where the paint cannot be told from the road (both over-exposed, say); a
            yellow line whose lightness is lost may still show by its colour.
        """
        if not self.sc.conditions.glare:
            return np.zeros(np.shape(x), bool)
        look = self.look
        cover = look.paint * (0.55 if self.sc.conditions.worn else 1.0)
        lit = GLARE_GLOW * self.glow(t, np.asarray(x, np.float64), np.asarray(y, np.float64))
        contrast = np.zeros(np.shape(lit))
        for colour, tint in zip(paint, look.tint, strict=True):
            road = look.surface_grey * tint * look.gain
            mixed = road + cover * (colour * look.gain - road)
            seen = np.abs(np.minimum(255, GLARE_GAIN * mixed + lit) - np.minimum(255, GLARE_GAIN * road + lit))
            contrast = np.maximum(contrast, seen)
        return contrast < MIN_VISIBLE_CONTRAST

    def unlit(self, x: np.ndarray, z: np.ndarray, paint: tuple[float, float, float],
              along: np.ndarray, u: np.ndarray | None = None, rel: np.ndarray | None = None) -> np.ndarray:
        """Tell where the night leaves a marking less than ``MIN_VISIBLE_CONTRAST`` from the road in every channel.

        Parameters
        ----------
        x, z : ndarray
            The marking's points across from the camera and ahead of it, m.
        paint : tuple of float
            The paint's colour, BGR 0-255.
        along : ndarray
            The paint there (:meth:`paint_along`), 0-1.
        u, rel : ndarray, optional
            Along the road and across from the ego lane's centre, m (for the lamps' pools).

        Returns
        -------
        ndarray of bool
            True where the paint cannot be told from the road (beyond the beams, say); all
            False by day.
        """
        if self.night is None:
            return np.zeros(np.shape(x), bool)
        look, n = self.look, self.night
        amb, beam = n.light(np.asarray(x, np.float32), np.asarray(z, np.float32), u, rel)
        a = np.asarray(along, np.float32) * np.float32(look.paint)
        contrast = np.zeros(np.shape(a), np.float32)
        for colour, tint in zip(paint, look.tint, strict=True):
            road = look.surface_grey * tint * look.gain
            mixed = (road * (1 - a) + a * colour * look.gain) * n.lit(amb, beam, a)
            bare = road * n.lit(amb, beam, 0.0)
            contrast = np.maximum(contrast, np.abs(np.minimum(255, mixed) - np.minimum(255, bare)))
        return contrast < MIN_VISIBLE_CONTRAST

    # -- appearance -------------------------------------------------------------------------
    def _sky_rows(self, ground: np.ndarray) -> int:
        """Give how many of the band's top rows hold sky (samples that meet no road)."""
        if ground is self.ground and self._level_sky_rows is not None:
            return self._level_sky_rows
        rows = np.flatnonzero(~ground.all(axis=1))
        n = int(rows[-1]) + 1 if rows.size else 0
        if ground is self.ground:
            self._level_sky_rows = n
        return n

    def _tex(self, a: np.ndarray, b: np.ndarray, tile: np.ndarray, sa: float, sb: float) -> np.ndarray:
        m = tile.shape[0] - 1  # tiles are a power of two wide: "& m" is "% (m + 1)", also below zero
        with np.errstate(invalid="ignore"):  # near the horizon of a sharp curve, past int32: any texel does
            i, j = (a * sa).astype(np.int32), (b * sb).astype(np.int32)
        i &= m
        i *= tile.shape[1]
        j &= m
        i += j
        return tile.ravel().take(i)  # tile[i & m, j & m], as one gather from the flat tile

    def render(self, t: float) -> np.ndarray:
        """Render the distorted frame at a time.

        Parameters
        ----------
        t : float
            Time, s.

        Returns
        -------
        (H, W, 3) uint8 ndarray
            The frame, BGR.
        """
        if not t >= 0:  # distances along the road are then never negative: fmod is their remainder
            raise LaneFinderError(f"a frame's time must be 0 s or more, not {t}")
        g = self.geometry(t)
        c, look = self.sc.conditions, self.look
        X, Z, ground = self.X, self.Z, self.ground
        if self.hills:
            hit = self.meet_road(g, self.rays)
            ground = np.isfinite(hit)
            hit = np.where(ground, hit, 0).astype(np.float32)
            X, Z = hit * self.rays[0], hit * self.rays[2]
            Zc = np.where(ground, Z, 0).astype(np.float32)
        else:
            Zc = self.Zc
        # float32 throughout (np.asarray casts only what is not float32 already: no copies).
        xc = np.asarray(self.centre(g, Zc), np.float32)
        rel = np.asarray(X - xc, np.float32)  # lateral position relative to the lane centre
        u = np.asarray(Zc + g["travelled"], np.float32)  # distance along the road (>= 0), anchored to it
        width = g["width"]
        half = width / 2
        tex = self._tex(rel + 100, u, self.texture, 24, 10)
        base = np.float32(look.surface_grey) + np.float32(look.texture_contrast) * tex
        if c.pavement_changes:
            concrete = (np.floor(u / 35.0) % 2) == 1
            base = np.where(concrete, np.float32(165) + 6 * tex, base)
        if c.seams:
            base = base + np.where(rel > 0.35, np.float32(-22), np.float32(0)) + np.where(
                np.abs(rel + 0.9) < 0.04, np.float32(-35), np.float32(0))
        if look.concrete_joints:  # u >= 0
            base = base - np.where(_remainder_below(u, 4.5, 0.06), np.float32(30), np.float32(0))
        if look.streaks > 0:
            in_lane = _remainder(rel + half, width) - half  # each lane's own wheel paths
            base = base - np.float32(look.streaks) * (np.exp(-((np.abs(in_lane) - 0.85) / 0.25) ** 2))
        if look.tar_seams > 0:
            crack = self._tex(rel + 37, u, self.cracks, 18, 6)
            joint = np.abs(rel - look.seam_rel_m) < 0.05
            base = base - np.float32(look.tar_seams) * np.maximum(crack, joint.astype(np.float32))
        left_edge = {"white-dashed": -1.5 * width, "edge": -half}.get(look.left, -half)
        if self.oncoming_lane:
            left_edge = min(left_edge, -1.5 * width)  # the oncoming lane
        right_edge = half + 0.3 if c.roadside else 1.5 * width + 1.5
        off_road = (rel < left_edge - (0.3 if look.left == "edge" else 1.2)) | (rel > right_edge)
        tint = look.tint
        grass = ((60, 10), (95, 12), (100, 10))  # B, G, R: level and grain off the road
        # Three planes interleaved by OpenCV (NumPy's strided writes into one array took twice as
        # long); the band always holds a row of road (see __init__).
        planes = [np.where(off_road, lvl + k * tex, base * tn) for (lvl, k), tn in zip(grass, tint, strict=True)]
        img = cv2.merge(planes)
        if c.roadside:
            self._verge(img, rel, u, off_road, right_edge)

        shine = np.zeros(rel.size, np.float32) if self.night is not None else None  # paint cover, for the beams

        def paint(centre_rel: float, color: tuple[float, float, float], dashed: bool, alpha: float = 1.0,
                  width: float = look.marking_m) -> None:
            d = np.abs(rel - centre_rel).ravel()
            # Only the samples the marking covers at all are shaded.
            idx = np.flatnonzero(d < width / 2 + 0.0075)
            if idx.size == 0:
                return
            d, uu = d[idx], u.ravel()[idx]
            # Coverage of the marking within this sample (smooth edge over ~1.5 cm).
            cov = np.clip((width / 2 - d) / 0.015 + 0.5, 0, 1)
            cov = cov * self.paint_along(uu, dashed)
            a = (cov * (alpha * look.paint))[:, None].astype(np.float32)
            flat = img.reshape(-1, 3)
            flat[idx] = flat[idx] * (1 - a) + a * np.asarray(color, np.float32)
            if shine is not None:
                shine[idx] = np.maximum(shine[idx], a[:, 0])

        for m in self.road_markings(width):
            paint(m.centre_m, m.colour, m.dashed, width=m.width_m)
        if c.tree_shadows or c.bridge_shadow:
            shade = np.ones(rel.shape, np.float32)
            if c.tree_shadows:
                blob = self._tex(rel + 50 + look.shadow_skew * u, u, self.blobs, 1.2, 0.6)
                shade = np.where(blob > 0.5, np.float32(look.shadow_darkness), shade)
            if c.bridge_shadow:
                shade = np.where(_remainder_below(u, 90.0, 14.0), np.float32(0.3), shade)
            if look.gain != 1.0:
                shade = shade * np.float32(look.gain)
            img *= shade[..., None]
        elif look.gain != 1.0:  # an even shade: the same products as with an array of it
            img *= np.float32(look.gain)
        night = self.night
        if night is not None and shine is not None:
            amb, beam = night.light(X, Zc, u, rel)
            img *= night.lit(amb, beam, shine.reshape(rel.shape))[..., None]
        sky_band, sky_full = self.sky_band, self.sky_full
        if night is not None:
            sky_band, sky_full = sky_band * np.float32(0.04) + 3, sky_full * np.float32(0.04) + 3
        sky = ~ground[:self._sky_rows(ground)]  # only the band's top rows hold sky
        img[:sky.shape[0]][sky] = sky_band[:sky.shape[0]][sky]
        w, h = self.size
        out = sky_full.copy()
        s = self.s
        out[self.r0 // s:] = cv2.resize(img, (w, h - self.r0 // s), interpolation=cv2.INTER_AREA)
        for grey, poly in self.vehicles(t, g):
            if night is None:
                cv2.fillPoly(out, [np.round(poly).astype(np.int32)], (grey, grey, grey * 1.05), cv2.LINE_AA)
                continue
            dark = 0.12 * grey
            cv2.fillPoly(out, [np.round(poly).astype(np.int32)], (dark, dark, dark * 1.05), cv2.LINE_AA)
            # Tail lights: 0.4 of the way up, 0.15 of the width in from each side.
            bl, br, tr, tl = poly
            for side, top in ((bl, tl), (br, tr)):
                other = br if side is bl else bl
                lamp = side + 0.4 * (top - side) + 0.15 * (other - side)
                r = max(1, round(0.07 * float(np.hypot(*(br - bl)))))
                cv2.circle(out, (round(float(lamp[0])), round(float(lamp[1]))), r, (40, 40, 250), -1, cv2.LINE_AA)
        if night is not None:
            self._night_lights(out, t, g)
            rng = np.random.default_rng([self.seed, round(t * 1000)])
            out = out + rng.normal(0.0, night.noise, out.shape).astype(np.float32)
        if c.glare:
            yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
            out = out * GLARE_GAIN + GLARE_GLOW * self.glow(t, xx, yy)[..., None]
        return np.clip(out, 0, 255).astype(np.uint8)

    def _reflection(self, out: np.ndarray, g: dict, x: float, up: float, z: float, r: float,
                    colour: tuple[float, float, float]) -> None:
        """Add a light's reflection in a wet road (in place): a soft streak from its foot towards the camera.

        The light ``up`` m over the road at ``(x, z)`` is mirrored ``up`` m below it; roughness
        draws the mirror image out along the vertical through the light, from its foot down to
        1.6 times as deep.  That vertical is projected through the lens point by point (it bends
        with the distortion as the road's lines do).
        """
        h, w = out.shape[:2]
        y = float(self.road_y(g, z))
        pts = np.column_stack([np.full(40, x), y + np.linspace(0.0, 1.6 * up, 40), np.full(40, z)])
        cam = pts @ self.rot.T
        k = np.asarray(self.camera.camera_matrix, np.float64)
        pin = (cam @ k.T)[:, :2] / (cam @ k.T)[:, 2:]
        ok = (pin[:, 0] > -0.1 * w) & (pin[:, 0] < 1.1 * w) & (pin[:, 1] > -0.1 * h) & (pin[:, 1] < 1.1 * h)
        ok = np.logical_and.accumulate(ok)
        if ok.sum() < 2:
            return
        rvec, _ = cv2.Rodrigues(self.rot)
        img, _ = cv2.projectPoints(pts[ok], rvec, np.zeros(3), k, self.camera.dist_coeffs)
        img = img.reshape(-1, 2)
        pad = int(4 * r + 20)
        a, b = max(0, int(img[:, 0].min()) - pad), min(w, int(img[:, 0].max()) + pad + 1)
        c, d = max(0, int(img[:, 1].min()) - pad), min(h, int(img[:, 1].max()) + pad + 1)
        if a >= b or c >= d:
            return
        layer = np.zeros((d - c, b - a), np.float32)
        cv2.polylines(layer, [np.round(img - [a, c]).astype(np.int32)], False, 1.0, max(1, round(1.5 * r)), cv2.LINE_AA)
        layer = cv2.GaussianBlur(layer, (0, 0), max(1.0, 0.6 * r), sigmaY=max(2.0, 1.5 * r))
        out[c:d, a:b] += layer[..., None] * np.asarray(colour, np.float32)

    def _night_lights(self, out: np.ndarray, t: float, g: dict) -> None:
        """Draw the street lamps and oncoming headlights with their glow, and on a wet road every light's reflection."""
        n = self.night
        if n is None:
            return
        lights = []  # (x, height above the road, z, radius m, colour BGR, glow; None: drawn already)
        if n.lamp_spacing_m > 0:
            sp = n.lamp_spacing_m
            first = math.ceil((g["travelled"] + 4 - sp / 2) / sp)
            for k in range(first, first + int(150 // sp) + 1):
                z = k * sp + sp / 2 - g["travelled"]
                if 10 < z < 150:
                    lights.append((float(self.centre(g, z)) + n.lamp_rel_m, 8.0, z, 0.3, (170, 215, 255), 0.6))
        if self.oncoming_lane:
            z = 150.0 - 35.0 * ((t + self.seed % 5) % 5.0)
            if 8 < z < 150:
                x = float(self.centre(g, z)) - g["width"]
                lights += [(x + dx, 0.65, z, 0.12, (255, 250, 240), 1.0) for dx in (-0.75, 0.75)]
        if n.wet:
            for v in self.look.vehicles:
                z = v.z_at(t)
                if 4 < z < 150:
                    x = float(self.centre(g, z)) + v.lane * g["width"]
                    lights += [(x + dx, 0.6, z, 0.07, (40, 40, 250), None) for dx in (-0.63, 0.63)]
        if not lights:
            return
        k = np.asarray(self.camera.camera_matrix, np.float64)
        rvec, _ = cv2.Rodrigues(self.rot)
        heads = np.array([[x, float(self.road_y(g, z)) - up, z] for x, up, z, *_ in lights])
        img, _ = cv2.projectPoints(heads, rvec, np.zeros(3), k, self.camera.dist_coeffs)
        img = img.reshape(-1, 2)
        cam = heads @ self.rot.T
        pin = (cam @ k.T)[:, :2] / (cam @ k.T)[:, 2:]
        w, h = self.size
        inside = (pin[:, 0] > -0.1 * w) & (pin[:, 0] < 1.1 * w) & (pin[:, 1] > -0.1 * h) & (pin[:, 1] < 1.1 * h)
        fx = float(k[0, 0])
        glow = np.zeros(out.shape[:2], np.float32)
        bloom = np.zeros(out.shape[:2], np.float32)  # a camera blooms around headlights coming at it
        for (x, up, z, radius, colour, strength), head, ok in zip(lights, img, inside, strict=True):
            if not ok:
                continue
            r = max(1.0, fx * radius / z)
            if strength is not None:
                centre = (round(float(head[0])), round(float(head[1])))
                cv2.circle(glow, centre, max(1, round(3 * r)), strength, -1, cv2.LINE_AA)
                cv2.circle(out, centre, max(1, round(r)), colour, -1, cv2.LINE_AA)
                if strength >= 1.0:
                    cv2.circle(bloom, centre, max(2, round(6 * r)), 1.0, -1, cv2.LINE_AA)
            if n.wet:
                self._reflection(out, g, x, up, z, r, tuple(0.5 * (strength or 0.5) * c for c in colour))
        out += cv2.GaussianBlur(glow, (0, 0), 8)[..., None] * np.float32(160)
        if bloom.any():
            out += cv2.GaussianBlur(bloom, (0, 0), 0.03 * w)[..., None] * np.float32(90)

    def _verge(self, img: np.ndarray, rel: np.ndarray, u: np.ndarray, off_road: np.ndarray, right_m: float) -> None:
        """Draw a cluttered verge over the grass (in place): dirt, dry stalks and a guard rail."""
        patches = self._tex(rel + 7, u, self.blobs, 0.9, 0.35)  # sunlit dirt and shade, metres across
        stalks = self._tex(rel + 3, u, self.texture, 7, 0.7)  # thin, long along the road
        level = np.clip(135 + 30 * patches, 60, 200) + np.where(stalks > 1.6, np.float32(60), np.float32(0))
        rail_at = np.abs(rel - (right_m + 0.8))
        level = np.where(rail_at < 0.1, np.float32(215), level)
        level = np.where((rail_at < 0.14) & ((u % 2.0) < 0.15), np.float32(55), level)  # posts
        for ch, tint in enumerate((0.8, 0.95, 1.05)):  # a warm, dusty colour
            img[..., ch] = np.where(off_road, level * tint, img[..., ch])

    def vehicles(self, t: float, g: dict) -> list[tuple[float, np.ndarray]]:
        """Give the vehicles ahead as image polygons, far to near (the order to draw them).

        Parameters
        ----------
        t : float
            Time, s.
        g : dict
            From :meth:`geometry` at ``t``.

        Returns
        -------
        list of (float, (4, 2) ndarray)
            Each vehicle's grey level and the corners of its rear in the distorted frame, pixels.
        """
        out = []
        rvec, _ = cv2.Rodrigues(self.rot)
        for v in sorted(self.look.vehicles, key=lambda v: -v.z_at(t)):
            z = v.z_at(t)
            h_cam = float(self.road_y(g, z))
            x = float(self.centre(g, z)) + v.lane * g["width"]
            pts = np.array([[x - 0.9, h_cam, z], [x + 0.9, h_cam, z], [x + 0.9, h_cam - 1.5, z],
                            [x - 0.9, h_cam - 1.5, z]])
            img, _ = cv2.projectPoints(pts, rvec, np.zeros(3), self.camera.camera_matrix, self.camera.dist_coeffs)
            img = img.reshape(-1, 2)
            if self.hills:  # behind a crest: only what rises above the crest's edge shows
                img = self._behind_crest(g, x, z, img, rvec)
                if img is None:
                    continue
            out.append((v.grey, img))
        return out

    def _behind_crest(self, g: dict, x: float, z: float, img: np.ndarray, rvec: np.ndarray) -> np.ndarray | None:
        """Cut a vehicle's rear (corners: bottom two, then top two) at the edge of a crest before it.

        The road nearer than ``z`` hides what lies below its highest point in the image: the
        bottom corners are raised to that row; None when all of the rear is hidden.
        """
        near = np.linspace(0.5, z, 400)
        slope = self.road_y(g, near) / near  # below the level horizon: the smallest shows highest
        k = int(np.argmin(slope))
        if slope[k] >= float(self.road_y(g, z)) / z:
            return img  # the road up to the vehicle is all in view
        edge, _ = cv2.projectPoints(np.array([[x, float(self.road_y(g, near[k])), near[k]]]), rvec, np.zeros(3),
                                    self.camera.camera_matrix, self.camera.dist_coeffs)
        row = float(edge.reshape(2)[1])
        if img[2:, 1].min() >= row:
            return None
        out = img.copy()
        out[:2, 1] = np.minimum(out[:2, 1], row)
        return out

    def frames(self, n: int, fps: float = 25.0) -> Iterator[tuple[np.ndarray, FrameTruth]]:
        """Render a sequence.

        Parameters
        ----------
        n : int
            Frames.
        fps : float, optional
            Frame rate, frames/s.

        Yields
        ------
        tuple of (ndarray, FrameTruth)
            Each frame (BGR) with its truth.
        """
        for i in range(n):
            t = i / fps
            g = self.geometry(t)
            yield self.render(t), self.truth(i, t, g)

    # -- the exact bird's-eye set-up --------------------------------------------------------
    def birdseye_config(self, size: tuple[int, int] = VIEW_SIZE_PX, lane_px: float = LANE_SPAN_PX) -> dict:
        """Give the config section that makes the bird's-eye view an exact metric view of the road.

        Parameters
        ----------
        size : tuple of int, optional
            (width, height) of the view, pixels.
        lane_px : float, optional
            Pixels a lane of ``LANE_WIDTH_M`` spans across the view.

        Returns
        -------
        dict
            The ``birdseye`` section: the road from ``z_near`` to ``z_far`` ahead.
        """
        half = LANE_WIDTH_M / 2
        pts = np.array([[-half, self.mount.height_m, self.z_far], [half, self.mount.height_m, self.z_far],
                        [half, self.mount.height_m, self.z_near], [-half, self.mount.height_m, self.z_near]])
        cam = pts @ self.rot.T
        k = self.camera.camera_matrix
        src = (cam @ k.T)[:, :2] / (cam @ k.T)[:, 2:]
        dst = [list(p) for p in default_dst(size, lane_px)]
        return {
            "reference_size": list(self.size), "src": [[round(float(x), 4), round(float(y), 4)] for x, y in src],
            "size": list(size), "dst": dst, "xm_per_px": LANE_WIDTH_M / lane_px,
            "ym_per_px": (self.z_far - self.z_near) / size[1],
        }


#: Peak bytes per frame pixel while rendering (the supersampled ground, its textures and masks):
#: measured 450 at 1280x720 and 2560x1440 (peak resident size less the interpreter's 150 MB).
RENDER_BYTES_PER_PX = 450
#: The memory ``synth`` may use, MB: 4K frames (3840x2160, about 3.6 GB) fit.
RENDER_BUDGET_MB = 8192


def check_render_memory(frame_size: tuple[int, int], budget_mb: int | None = None) -> None:
    """Refuse frames too large to render within the memory budget, before any is rendered.

    Parameters
    ----------
    frame_size : tuple of int
        (width, height) of the frames, pixels.
    budget_mb : int, optional
        The budget, MB (default ``RENDER_BUDGET_MB``).

    Raises
    ------
    LaneFinderError
        When rendering would need more; the message gives both.

    Examples
    --------
    >>> check_render_memory((1280, 720))
    >>> check_render_memory((16384, 16384))
    Traceback (most recent call last):
    ...
    lanefinder.errors.LaneFinderError: rendering 16384x16384 frames needs about 115200 MB, over the 8192 MB ...
    """
    budget = RENDER_BUDGET_MB if budget_mb is None else budget_mb
    w, h = frame_size
    need = w * h * RENDER_BYTES_PER_PX / 2**20
    if need > budget:
        raise LaneFinderError(f"rendering {w}x{h} frames needs about {need:.0f} MB, over the {budget} MB synth "
                              "allows; use a camera file for a smaller image size")


def road_start_s(scenario: Scenario, seed: int) -> float:
    """Draw from a seed where in a scenario's cycle of geometry a sequence starts.

    Parameters
    ----------
    scenario : Scenario
        The scenario (its ``period_s``).
    seed : int
        The sequence's seed.

    Returns
    -------
    float
        Seconds into the cycle, from 0 to ``scenario.period_s``.

    Examples
    --------
    >>> a, b = road_start_s(SCENARIOS["winding"], 101), road_start_s(SCENARIOS["winding"], 102)
    >>> 0 <= a < 7 and 0 <= b < 7 and a != b
    True
    """
    return float(np.random.default_rng([int(seed), 0x0AD5]).uniform(0.0, scenario.period_s))


def write_sequence(scenario: str | Scenario, n_frames: int, out_dir: str | Path, seed: int = 0,
                   camera: CameraModel | None = None, mount: Mount | None = None, fps: int = 25,
                   progress: bool = False, randomise: bool = False, road_from_seed: bool = False) -> Path:
    """Write a synthetic sequence: video.mp4, gt.jsonl, events_gt.jsonl, camera.json, config.toml, scenario.json.

    ``events_gt.jsonl`` holds the true lane events: :func:`lanefinder.events.detect_events`
    with the default ``events`` settings over the exact offset and width of every frame.
    ``config.toml`` holds the sequence's set-up (``[camera]``, ``[birdseye]``) and those
    ``[events]`` settings, so that its events are found with the settings its truth was; every
    other setting is left to the defaults of the lanefinder that reads it.

    Parameters
    ----------
    scenario : str or Scenario
        A name from ``SCENARIOS`` or a scenario.
    n_frames : int
        Frames to render.
    out_dir : str or Path
        The folder (created if needed).
    seed : int, optional
        Seed of the appearance.
    camera : CameraModel, optional
        The lens; default the Udacity camera.
    mount : Mount, optional
        Where it sits; default :class:`Mount`.
    fps : int, optional
        Frame rate, frames/s.
    progress : bool, optional
        Show a progress bar.
    randomise : bool, optional
        Draw the road's look, the lane width and the camera mount from the seed
        (:meth:`Appearance.random`); ``mount``, when given, still wins.
    road_from_seed : bool, optional
        Draw from the seed, too, where in the road's cycle the sequence starts
        (:func:`road_start_s`; ``scenario.json`` records it as ``start_s``): without it every
        seed drives the same stretch of road, its first seconds.

    Returns
    -------
    Path
        The folder.

    Raises
    ------
    LaneFinderError
        For an unknown scenario, fewer than one frame, frames too large to render
        (:func:`check_render_memory`) or too small to find a lane in.

    Examples
    --------
    >>> import tempfile
    >>> out = write_sequence("straight", 2, tempfile.mkdtemp())  # doctest: +SKIP
    >>> sorted(p.name for p in out.iterdir())  # doctest: +SKIP
    ['camera.json', 'config.toml', 'events_gt.jsonl', 'gt.jsonl', 'scenario.json', 'video.mp4']
    >>> write_sequence("moon", 2, tempfile.mkdtemp())
    Traceback (most recent call last):
    ...
    lanefinder.errors.LaneFinderError: unknown scenario 'moon'; choose from straight, curve, ...
    """
    from .camera import udacity_camera
    from .config import SETUP_SECTIONS, config_from_dict, dump_config
    from .events import detect_events, write_events
    from .video import VideoInfo, VideoSink

    if isinstance(scenario, str):
        if scenario not in SCENARIOS:
            raise LaneFinderError(f"unknown scenario {scenario!r}; choose from {', '.join(SCENARIOS)}")
        scenario = SCENARIOS[scenario]
    if n_frames < 1:
        raise LaneFinderError("--frames must be at least 1")
    out = Path(out_dir)
    cam = camera or udacity_camera()
    check_render_memory(cam.image_size)
    from .pipeline import MIN_FRAME_PX

    if cam.image_size[0] < MIN_FRAME_PX[0] or cam.image_size[1] < MIN_FRAME_PX[1]:  # `video` would refuse them
        raise LaneFinderError(f"frames of {cam.image_size[0]}x{cam.image_size[1]} are too small to find a lane in: "
                              f"at least {MIN_FRAME_PX[0]}x{MIN_FRAME_PX[1]}")
    source = Path(cam.source) if cam.source and Path(cam.source).is_file() else None
    inputs = [source] if source else []
    check_outputs([out / n for n in ("video.mp4", "gt.jsonl", "events_gt.jsonl", "camera.json", "config.toml",
                                     "scenario.json")], inputs)  # before any rendering
    look = Appearance.random(seed) if randomise else Appearance()
    if randomise:
        scenario = replace(scenario, width_m=(look.lane_width_m, min(scenario.width_m[1], 0.1)))
    start_s = road_start_s(scenario, seed) if road_from_seed else 0.0
    renderer = Renderer(cam, mount or look.mount, scenario, seed, appearance=look, start_s=start_s)
    w, h = cam.image_size
    info = VideoInfo(w, h, Fraction(fps), n_frames, n_frames / fps, "h264")
    rows, truth_rows = [], []
    from tqdm import tqdm

    # All six files are put in place together, only when all are written.
    with OutputSet(inputs=inputs) as outs:
        sink = VideoSink(out / "video.mp4", info, preset="veryfast", crf=14, outputs=outs)
        try:
            for img, truth in tqdm(renderer.frames(n_frames, fps), total=n_frames, disable=None if progress else True,
                                   desc=scenario.name, unit="frame"):
                sink.write(img)
                rows.append(json.dumps(truth.to_json()))
                truth_rows.append({"frame": truth.frame, "time_s": truth.time_s, "state": "tracking",
                                   "offset_m": truth.offset_m, "width_m": truth.width_m})
            sink.close()
        except BaseException:
            sink.discard()
            raise
        atomic_write_text(out / "gt.jsonl", "\n".join(rows) + "\n", outputs=outs)
        atomic_write_text(out / "camera.json", json.dumps(replace(cam, views=()).to_dict(), indent=2) + "\n",
                          outputs=outs)
        cfg = config_from_dict({"camera": {"model": "camera.json"}, "birdseye": renderer.birdseye_config()})
        atomic_write_text(out / "config.toml", dump_config(cfg, sections=(*SETUP_SECTIONS, "events")), outputs=outs)
        write_events(out / "events_gt.jsonl", detect_events(truth_rows, fps, cfg.events), outputs=outs)
        described = asdict(scenario)
        if not scenario.manoeuvres:
            del described["manoeuvres"]  # scenario.json as before manoeuvres existed
        if not any(scenario.vertical_curvature):
            del described["vertical_curvature"]  # (and as before hills)
        if not scenario.conditions.roadside:
            del described["conditions"]["roadside"]
        meta = {"scenario": described, "seed": seed, "frames": n_frames, "fps": fps,
                **({"start_s": round(start_s, 6)} if road_from_seed else {}),
                "mount": asdict(renderer.mount), "z_near_m": renderer.z_near, "z_far_m": renderer.z_far}
        if randomise:
            meta["appearance"] = {k: v for k, v in asdict(look).items() if k not in ("mount", "lane_width_m")}
        atomic_write_text(out / "scenario.json", json.dumps(meta, indent=2) + "\n", outputs=outs)
    return out
