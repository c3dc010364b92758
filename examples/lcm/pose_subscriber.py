#!/usr/bin/env python3
"""Receives siteposed's poses and prints one line per pose, in Python alone.

Debian 12 has no Python `lcm` module, and none is needed: the classes that
lcm-gen makes (sitepose-dev: /usr/lib/python3/dist-packages/sitepose/) encode
and decode with the standard library, and LCM's UDP multicast transport is a
plain datagram per small message:

    uint32 magic 0x4c433032 ("LC02"), big-endian
    uint32 sequence number, big-endian
    channel name, NUL-terminated
    payload: the encoded message (its 8-byte type fingerprint first)

Messages over about 64 kB come as fragments (magic "LC03"); pose_t is about
600 bytes and never does, so they are skipped here.

Usage: pose_subscriber.py [--count N] [--url URL] [--channel NAME]
(as pose_subscriber.cpp; only udpm:// URLs).
"""

import argparse
import os
import socket
import struct
import sys
import urllib.parse

from sitepose import pose_t

MAGIC_SHORT = 0x4C433032
DEFAULT_URL = "udpm://239.255.76.67:7667?ttl=0"


def parse_udpm(url):
    """(group, port) of an LCM udpm URL."""
    parsed = urllib.parse.urlparse(url)
    if parsed.scheme != "udpm":
        raise ValueError(f"{url}: only udpm:// URLs can be read without the lcm module")
    group, _, port = parsed.netloc.partition(":")
    return group or "239.255.76.67", int(port or 7667)


def open_socket(group, port):
    """A socket in the multicast group, bound as LCM binds (any address)."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM, socket.IPPROTO_UDP)
    # Several receivers on one host share the port, as LCM's own do.
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    sock.bind(("", port))
    membership = struct.pack("4s4s", socket.inet_aton(group), socket.inet_aton("0.0.0.0"))
    sock.setsockopt(socket.IPPROTO_IP, socket.IP_ADD_MEMBERSHIP, membership)
    return sock


def split_packet(data):
    """(channel, payload) of a small LCM message, None for anything else."""
    if len(data) < 9:
        return None
    magic, _sequence = struct.unpack(">II", data[:8])
    end = data.find(b"\0", 8)
    if magic != MAGIC_SHORT or end < 0:
        return None
    return data[8:end].decode("utf-8", "replace"), data[end + 1:]


def format_pose(m):
    # Steer only on STATE_OK; FRAME_SITE: position is E, N, U in metres from
    # the site origin, lat/lon/height WGS84 (pose_t.lcm documents each field).
    return (
        f"pose seq={m.seq} utime={m.utime} state={m.state} frame={m.frame} "
        "position=%.6f,%.6f,%.6f orientation=%.6f,%.6f,%.6f,%.6f velocity=%.6f,%.6f,%.6f "
        "lat=%.9f lon=%.9f height=%.4f heading=%.4f position_std=%.6f"
        % (*m.position, *m.orientation, *m.velocity, m.latitude_deg, m.longitude_deg, m.height_m,
           m.heading_deg, m.position_std_m))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=0, help="exit after N poses (default: run until killed)")
    parser.add_argument("--url", default=os.environ.get("LCM_DEFAULT_URL") or DEFAULT_URL)
    parser.add_argument("--channel", default="SITEPOSE_POSE", help="outputs.lcm.pose_channel")
    args = parser.parse_args()
    sock = open_socket(*parse_udpm(args.url))
    received = 0
    while args.count == 0 or received < args.count:
        message = split_packet(sock.recv(65536))
        if message is None or message[0] != args.channel:
            continue
        try:
            pose = pose_t.decode(message[1])
        except ValueError as e:  # another type on this channel, or a pose_t of another version
            print(f"{message[0]}: {e}", file=sys.stderr)
            continue
        print(format_pose(pose), flush=True)
        received += 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
