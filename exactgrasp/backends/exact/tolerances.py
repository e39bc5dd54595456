"""Every tolerance and error-bound coefficient of the exact backend, each with its reason.

The derivations are in ``docs/exact-backend.md`` ("Why it is exact"); the kernels read these
names as compile-time constants.
"""

from __future__ import annotations

import numpy as np

#: Relative agreement demanded of every volume with the plain boolean (see
#: `exactgrasp.backends.exact.reference.agrees`).
RTOL = 1e-9

# -- rounding units -----------------------------------------------------------------------------

#: Unit roundoff of double precision (round to nearest): every error bound is a multiple.
U = 2.0**-53
#: Unit roundoff of ``numpy.longdouble`` (80-bit on x86-64), in which the fixed hand's face and
#: edge terms are computed once.
U_EXTENDED = float(np.finfo(np.longdouble).eps) / 2
#: A bound computed in floating point (a vertex length, an extent) is multiplied by this so that
#: it still bounds the exact value after its own rounding (relative, far above a few U).
ROUNDING_PAD = 1.0 + 1e-12
#: Smallest coordinate bound used: a mesh of zero extent still gets a positive scale.
LENGTH_FLOOR = 1e-300

# -- grids and filters (fractions of a grid cell) ------------------------------------------------

#: Cells are closed and grown by this fraction of a cell wherever a face is assigned to a cell or
#: a box is clipped to one: fixed-axis projections err by a few U relative to the cell, far less.
GRID_MARGIN = 1e-9
#: Least tolerance of a floating-point plane test, as a fraction of the hand's cell: far above the
#: rounding of well-shaped faces; ill-conditioned ones widen it (`PLANE_ERR`).
PLANE_TOL = 1e-9
#: A face run's bounding-sphere radius is widened by this fraction of the mesh's coordinate scale
#: (at least 1) to cover the rounding of the centre and the distances.
RADIUS_PAD = 1e-12
#: A hand cell's summed face normal shorter than this fraction of the longest one has no usable
#: direction: the cell's slab axis is then the x axis.
NORMAL_FLOOR = 1e-12

# -- plane and term error coefficients -----------------------------------------------------------

#: The seeds' filters read faces' planes and edge normals rounded to single precision: a distance
#: with them errs by at most ``2**-24 (|n|_1 |x|_inf + |offset|) + 8 U G <= 2**-22 G`` more
#: (``_seeds.pxd``; their tolerances add it, times the coordinate bound G).
FILTER_ERR = 2.0**-22

#: A plane distance ``n·x - n·a`` with the unit normal of a face from its cross product errs by
#: at most ``U G (25 + 14.2 kappa)`` (``G`` bounds every coordinate, ``kappa`` the face's
#: conditioning `face_conditioning`; see docs/exact-backend.md): taken as ``32 (1 + kappa)``.
PLANE_ERR = 32.0
#: Conditioning beyond which the normal's direction error (7 U kappa, first order) is not
#: trusted: the face's plane tests then certify nothing and every decision takes the exact test.
KAPPA_MAX = 1e-2 / (7.0 * U)
#: Plane-distance error coefficient (times G) of a face beyond `KAPPA_MAX`: a distance that
#: large is impossible, so no side or box decision is taken in floating point.
PLANE_ERR_NONE = 4.0
#: Error of a face's ``D = (n·a) n`` against the exact one, times its area / 3 (what the face's
#: terms can lose, see docs), in units of ``U G |b - a| |c - a|``: at most 6 when conditioned
#: (taken as 8), 236 beyond `KAPPA_MAX` (taken as 240).
FACE_D_ERR, FACE_D_ERR_NONE = 8.0, 240.0
#: Rounding of one product term ``g · (p × q) / 6`` (and of an edge weight), in units of
#: ``U (|D_1|_1 + |D_2|_1) |p|_inf |q|_inf``: 3 by a first-order count, taken as 4.
TERM_ERR = 4.0
#: Rounding of a crossing parameter ``du / (du - dv)`` (absolute, the parameter lies in [0, 1]).
PARAM_ROUNDING = 4.0 * U
#: Rounding of the projections on the planes' common line, in units of U |direction|_1 G: each
#: projection errs by 3.1, the interpolation by twice that; taken as 16.
LINE_ROUNDING = 16.0
#: The common-line comparisons' own rounding (relative, far below this).
LINE_SLACK = 1.0 + 1e-6
#: A pose's volume is certified zero within its error bound times this (the bound's own
#: rounding, relative, is far below it).
BOUND_SLACK = 1.0 + 1e-6
#: Faces whose squared normal ``|N|²`` is at most this times the coordinate scale to the fourth
#: get ``D = 0``: such a face adds at most ``|a| sqrt(tiny) / 2`` to the volume, and skipping it
#: avoids dividing by zero.
TINY_FACE = 1e-30

# -- culling and the boolean fallback ------------------------------------------------------------

#: Surfaces farther apart than this times the coordinate scale are certainly disjoint, whatever
#: the BVH library's rounding.
CULL_GAP = 1e-7
#: The boolean fallback's error bound, in manifold3d tolerances times the surfaces' areas.
BOOLEAN_SLACK = 4.0
#: Its volumes below this many tolerances times the areas are rounding (8 units in the last
#: place of coordinates whose magnitude is 1e12 tolerances) and read 0.
BOOLEAN_ROUNDING = 8 * U * 1e12
