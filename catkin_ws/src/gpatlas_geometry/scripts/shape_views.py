"""The predicted surface seen from three sides (top, front, side), coloured by each vertex's
position sd, over the truth in light grey and with the touches' contacts marked: what a user
looks at to see whether a part (a mug's handle) is missing. Shared by the exploration's
plot_exploration.py and the bench's plot_bench.py; the caller has chosen matplotlib's backend.

The inputs are the files the project writes: writePly's ASCII PLY (x y z [variance]
[position_sd_m] per vertex, then triangles) and the contacts as points in metres."""
import numpy as np

# Colours saturate here: a few millimetres is what the stop rule asks for (5 mm by default).
CLIP_MM = 10.0
# Points drawn per cloud and view: enough to see a 1 cm handle, few enough to plot in a second.
MAX_POINTS = 4000
# (title, horizontal axis, vertical axis, depth axis, the viewer's side along it): orthographic
# views from above (+z), the front (-y) and the side (+x), each with right = +x or +y, up = +y
# or +z, as a camera with that position would see them.
VIEWS = (("top (from +z)", 0, 1, 2, 1.0), ("front (from -y)", 0, 2, 1, -1.0), ("side (from +x)", 1, 2, 0, 1.0))
AXIS_NAMES = "xyz"


def read_ply(path):
    """An ASCII PLY as writePly writes it: (vertices N x 3, faces M x 3, {property: N values})."""
    with open(path) as f:
        if f.readline().strip() != "ply":
            raise ValueError(f"{path}: not a PLY file")
        counts, properties, element = {}, [], None
        for line in f:
            words = line.split()
            if not words:
                continue
            if words[0] == "format" and words[1] != "ascii":
                raise ValueError(f"{path}: only ASCII PLY is read here")
            if words[0] == "element":
                element = words[1]
                counts[element] = int(words[2])
            elif words[0] == "property" and element == "vertex":
                properties.append(words[-1])
            elif words[0] == "end_header":
                break
        rows = [f.readline().split() for _ in range(counts.get("vertex", 0))]
        values = np.array(rows, dtype=float).reshape(-1, len(properties))
        faces = [f.readline().split()[1:4] for _ in range(counts.get("face", 0))]
    columns = {name: values[:, i] for i, name in enumerate(properties)}
    vertices = np.column_stack([columns["x"], columns["y"], columns["z"]]) if len(values) else np.zeros((0, 3))
    return vertices, np.array(faces, dtype=int).reshape(-1, 3), columns


def surface_points(vertices, faces, count, seed=0):
    """`count` points spread over the triangles by area (a mesh's vertices crowd where its
    triangles are small); the vertices themselves when there are no triangles."""
    rng = np.random.default_rng(seed)
    if len(faces) == 0:
        return vertices[rng.permutation(len(vertices))[:count]]
    a, b, c = (vertices[faces[:, k]] for k in range(3))
    area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
    if not area.sum() > 0.0:
        return vertices[rng.permutation(len(vertices))[:count]]
    chosen = rng.choice(len(faces), size=count, p=area / area.sum())
    r1, r2 = rng.random(count), rng.random(count)
    flip = r1 + r2 > 1.0
    r1[flip], r2[flip] = 1.0 - r1[flip], 1.0 - r2[flip]
    return a[chosen] + r1[:, None] * (b[chosen] - a[chosen]) + r2[:, None] * (c[chosen] - a[chosen])


def load_shape(predicted_ply, truth_ply=None, max_points=MAX_POINTS):
    """What draw_views draws: the predicted vertices (a seeded subsample) with their position
    sd in mm (NaN where the file has none), and a sample of the truth (None without one)."""
    vertices, _, columns = read_ply(predicted_ply)
    sd_mm = 1000.0 * columns["position_sd_m"] if "position_sd_m" in columns else np.full(len(vertices), np.nan)
    keep = np.random.default_rng(1).permutation(len(vertices))[:max_points]
    truth = None
    if truth_ply:
        truth_vertices, truth_faces, _ = read_ply(truth_ply)
        truth = surface_points(truth_vertices, truth_faces, max_points)
    return vertices[keep], sd_mm[keep], truth


def _limits(clouds, axis):
    values = np.concatenate([c[:, axis] for c in clouds if c is not None and len(c)])
    return values.min(), values.max()


def draw_views(axes, predicted, sd_mm, truth=None, contacts=None, clip_mm=CLIP_MM):
    """Three orthographic views into `axes` (three of them); returns the predicted points'
    scatter (for a colour bar), None when there are none or none has a position sd. Within a view the points nearer the
    viewer are drawn last, so a view shows the side facing it."""
    clouds = [predicted, truth, contacts]
    mappable = None
    for ax, (title, h, v, depth, side) in zip(axes, VIEWS):
        if truth is not None and len(truth):
            ax.scatter(truth[:, h], truth[:, v], s=2, c="0.82", linewidths=0, zorder=1)
        if len(predicted):
            order = np.argsort(side * predicted[:, depth])
            if np.isfinite(sd_mm).any():
                mappable = ax.scatter(predicted[order, h], predicted[order, v], s=3, c=np.minimum(sd_mm[order], clip_mm),
                                      cmap="viridis", vmin=0.0, vmax=clip_mm, linewidths=0, zorder=2)
            else:  # a mesh without position sd: its shape alone
                ax.scatter(predicted[order, h], predicted[order, v], s=3, c="tab:blue", linewidths=0, zorder=2)
        if contacts is not None and len(contacts):
            ax.scatter(contacts[:, h], contacts[:, v], s=14, marker="x", c="red", linewidths=0.8, zorder=3)
        if any(c is not None and len(c) for c in clouds):
            # One scale for every view: the same centimetre is as long in each.
            limits = [_limits(clouds, a) for a in range(3)]
            half = 0.525 * max(high - low for low, high in limits) + 1e-3
            for set_limits, a in ((ax.set_xlim, h), (ax.set_ylim, v)):
                centre = 0.5 * sum(limits[a])
                set_limits(centre - half, centre + half)
        ax.set_aspect("equal")
        ax.set_title(title, fontsize=9)
        ax.set_xlabel(f"{AXIS_NAMES[h]} (m)", fontsize=8)
        ax.set_ylabel(f"{AXIS_NAMES[v]} (m)", fontsize=8)
        ax.tick_params(labelsize=7)
    return mappable


def add_colour_bar(fig, mappable, axes, clip_mm=CLIP_MM):
    """The position sd's colour bar beside `axes`, saying where it saturates."""
    if mappable is None:
        return
    bar = fig.colorbar(mappable, ax=list(axes), fraction=0.03, pad=0.02)
    bar.set_label(f"position sd (mm), {clip_mm:g}+ clipped", fontsize=8)
    bar.ax.tick_params(labelsize=7)


# How to read the views, once per figure.
LEGEND = "grey: truth   colour: predicted surface (position sd)   red x: contacts"
