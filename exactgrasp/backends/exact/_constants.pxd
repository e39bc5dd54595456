# cython: language_level=3
"""The constants of `exactgrasp.backends.exact.tables` (integers) and
`exactgrasp.backends.exact.tolerances` (floats) as the compiled kernels read them, written out
from those modules (``tests/test_exact_kernel_goldens.py`` checks that they are equal, to the
bit)."""

cdef enum:
    OK = 0
    CULLED = 1
    DEGENERATE = 2
    OVERFLOW = 3
    GROW = 4
    ARRANGED = 5
    STAT_PAIRS = 0
    STAT_CROSSING = 1
    STAT_CELLS_TOUCHED = 2
    STAT_CELLS_INSIDE = 3
    STAT_CELLS_OUTSIDE = 4
    N_STATS = 5
    CHUNK = 16
    COTREE_CHUNK = 8
    COTREE_BLOCK = 8
    LIST_GROUP = 8
    BOX_MIN = 0
    BOX_MAX = 3
    CELL_AXIS = 0
    CELL_SLAB_LOW = 3
    CELL_SLAB_HIGH = 4
    CELL_BOX_MIN = 5
    CELL_BOX_MAX = 8
    CELL_BOUNDS_COLUMNS = 11
    FACE_NORMAL = 0
    FACE_OFFSET = 3
    FACE_ERR_COEF = 4
    FACE_D_COST = 5
    PLANE_COLUMNS = 6
    FACE_CORNERS = 6
    FACE_D = 15
    FACE_LINK = 18
    FACE_RECORD_COLUMNS = 24
    FACE_VERTICES = 0
    FACE_EDGES = 3
    FACE_ACROSS = 6
    FACE_OWNS = 9
    FACE_LINKS_COLUMNS = 16
    FILTER_NORMAL = 0
    FILTER_OFFSET = 3
    FILTER_SIDES = 4
    FILTER_SIDE_COLUMNS = 4
    FILTER_SIDE_OFFSET = 3
    FILTER_COLUMNS = 16
    SPHERE_CENTRE = 0
    SPHERE_RADIUS = 3
    PART_CELL = 0
    PART_FIRST_VERTEX = 1
    WEIGHT = 0
    WEIGHT_ERR = 1
    MOMENT_FORCE = 0
    MOMENT_TORQUE = 3
    MOMENT_COLUMNS = 6
    EDGE_MOMENTS_T1 = 0
    EDGE_MOMENTS_T2 = 6
    POINT_XYZ = 0
    POINT_ERR = 3
    POINT_STARTS = 4
    POINT_MESH = 5
    POINT_CORNER = 6
    POINT_COLUMNS = 7
    DIST_ERR = 3
    SEGMENT_FACE = 0
    SEGMENT_P = 1
    SEGMENT_Q = 4
    SEGMENT_NORMAL = 7
    SEGMENT_LINK = 10
    SEGMENT_OBJECT_FACE = 11
    SEGMENT_COLUMNS = 12

cdef extern from *:
    """
    static const double EG_RTOL = 1e-09;
    static const double EG_U = 1.1102230246251565e-16;
    static const double EG_U_EXTENDED = 5.421010862427522e-20;
    static const double EG_ROUNDING_PAD = 1.000000000001;
    static const double EG_LENGTH_FLOOR = 1e-300;
    static const double EG_GRID_MARGIN = 1e-09;
    static const double EG_PLANE_TOL = 1e-09;
    static const double EG_RADIUS_PAD = 1e-12;
    static const double EG_NORMAL_FLOOR = 1e-12;
    static const double EG_FILTER_ERR = 2.384185791015625e-07;
    static const double EG_PLANE_ERR = 32.0;
    static const double EG_KAPPA_MAX = 12867427506772.846;
    static const double EG_PLANE_ERR_NONE = 4.0;
    static const double EG_FACE_D_ERR = 8.0;
    static const double EG_FACE_D_ERR_NONE = 240.0;
    static const double EG_TERM_ERR = 4.0;
    static const double EG_PARAM_ROUNDING = 4.440892098500626e-16;
    static const double EG_LINE_ROUNDING = 16.0;
    static const double EG_LINE_SLACK = 1.000001;
    static const double EG_BOUND_SLACK = 1.000001;
    static const double EG_TINY_FACE = 1e-30;
    static const double EG_CULL_GAP = 1e-07;
    static const double EG_BOOLEAN_SLACK = 4.0;
    static const double EG_BOOLEAN_ROUNDING = 0.0008881784197001252;
    """
    const double RTOL "EG_RTOL"
    const double U "EG_U"
    const double U_EXTENDED "EG_U_EXTENDED"
    const double ROUNDING_PAD "EG_ROUNDING_PAD"
    const double LENGTH_FLOOR "EG_LENGTH_FLOOR"
    const double GRID_MARGIN "EG_GRID_MARGIN"
    const double PLANE_TOL "EG_PLANE_TOL"
    const double RADIUS_PAD "EG_RADIUS_PAD"
    const double NORMAL_FLOOR "EG_NORMAL_FLOOR"
    const double FILTER_ERR "EG_FILTER_ERR"
    const double PLANE_ERR "EG_PLANE_ERR"
    const double KAPPA_MAX "EG_KAPPA_MAX"
    const double PLANE_ERR_NONE "EG_PLANE_ERR_NONE"
    const double FACE_D_ERR "EG_FACE_D_ERR"
    const double FACE_D_ERR_NONE "EG_FACE_D_ERR_NONE"
    const double TERM_ERR "EG_TERM_ERR"
    const double PARAM_ROUNDING "EG_PARAM_ROUNDING"
    const double LINE_ROUNDING "EG_LINE_ROUNDING"
    const double LINE_SLACK "EG_LINE_SLACK"
    const double BOUND_SLACK "EG_BOUND_SLACK"
    const double TINY_FACE "EG_TINY_FACE"
    const double CULL_GAP "EG_CULL_GAP"
    const double BOOLEAN_SLACK "EG_BOOLEAN_SLACK"
    const double BOOLEAN_ROUNDING "EG_BOOLEAN_ROUNDING"
