"""Shared by the rostest image checks: an independent pinhole camera model (the renderer's camera
rebuilt from eye, target and focal length) and sensor_msgs/Image read from raw bytes (so no
Python sensor_msgs package is needed)."""
import math
import struct

W, H = 1280, 1024


def sub(a, b):
    return tuple(x - y for x, y in zip(a, b))


def dot(a, b):
    return sum(x * y for x, y in zip(a, b))


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def unit(a):
    n = math.sqrt(dot(a, a))
    return tuple(x / n for x in a)


class Camera:
    """Looks from eye at target with world z up; pixel rows grow downwards."""

    def __init__(self, eye, target, focal, width=W, height=H):
        self.eye, self.focal, self.width, self.height = eye, focal, width, height
        self.fwd = unit(sub(target, eye))
        self.right = unit(cross(self.fwd, (0.0, 0.0, 1.0)))
        self.down = cross(self.fwd, self.right)

    def project(self, p):
        """Pixel (u, v) of a world point, or None behind (or at) the eye."""
        d = sub(p, self.eye)
        z = dot(d, self.fwd)
        if z < 0.1:
            return None
        return (self.width / 2 + self.focal * dot(d, self.right) / z,
                self.height / 2 + self.focal * dot(d, self.down) / z)

    def horizon_row(self):
        """Row of the horizon at the centre column: level rays (b down + fwd) . e_z = 0."""
        return self.height / 2 + self.focal * (-self.fwd[2] / self.down[2])


def parse_image(buff):
    """(width, height, encoding, step, data) of a serialized sensor_msgs/Image."""
    off = 12  # seq, stamp
    (n,) = struct.unpack_from("<I", buff, off)
    off += 4 + n
    height, width = struct.unpack_from("<II", buff, off)
    off += 8
    (n,) = struct.unpack_from("<I", buff, off)
    encoding = buff[off + 4:off + 4 + n].decode()
    off += 4 + n + 1  # is_bigendian
    (step,) = struct.unpack_from("<I", buff, off)
    off += 4
    (n,) = struct.unpack_from("<I", buff, off)
    return width, height, encoding, step, buff[off + 4:off + 4 + n]


def px(data, u, v, width=W):
    i = 3 * (int(v) * width + int(u))
    return data[i], data[i + 1], data[i + 2]
