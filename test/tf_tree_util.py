"""World positions of frames from TF messages (/tf and /tf_static) as a tree: each frame's
transform from its parent, composed up to the world frame (no tf2_ros Python package needed)."""


def qmul(a, b):
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz)


def qrot(q, v):
    x, y, z, w = qmul(qmul(q, (v[0], v[1], v[2], 0.0)), (-q[0], -q[1], -q[2], q[3]))
    return (x, y, z)


class TfTree:
    def __init__(self):
        self.edges = {}  # child -> (parent, translation, rotation (x, y, z, w))

    def add(self, msg):
        for t in msg.transforms:
            tr, r = t.transform.translation, t.transform.rotation
            self.edges[t.child_frame_id] = (t.header.frame_id, (tr.x, tr.y, tr.z),
                                            (r.x, r.y, r.z, r.w))

    def pose(self, frame, world="world"):
        """(translation, rotation) of frame in world, or None when the chain does not reach it."""
        p, q = (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0)
        seen = set()
        while frame != world:
            if frame in seen or frame not in self.edges:
                return None
            seen.add(frame)
            parent, tr, r = self.edges[frame]
            # parent_T_frame * (p, q)
            rp = qrot(r, p)
            p = (tr[0] + rp[0], tr[1] + rp[1], tr[2] + rp[2])
            q = qmul(r, q)
            frame = parent
        return p, q

    def world_positions(self, world="world"):
        out = {}
        for child in self.edges:
            pq = self.pose(child, world)
            if pq is not None:
                out[child] = pq[0]
        return out
