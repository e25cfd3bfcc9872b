"""DTrack2 ASCII datagrams as a CAVE's DTrack sends them, for the tracker bridge's tests.

Room calibration "normal" (z up), bodies calibrated "due to room"; head glasses are body 0
(the DTrack2 window's body 1), a prop is body 3, the Flystick 2 is Flystick 0 (6 buttons,
a two-axis joystick). Each pose below is what the datagram carries, for the tests to
expect: the head turned 30° to the left (about z) and pitched 10° down, the Flystick
pitched 20° up. Lines end in CRLF, as DTrack2 writes them.
"""


def datagram(*lines: str) -> bytes:
    return "".join(line + "\r\n" for line in lines).encode("ascii")


HEAD_MM = (120.0, -350.5, 1712.3)
FLYSTICK_MM = (300.0, 400.0, 1100.0)

TRACKED = datagram(
    "fr 21753",
    "ts 39596.024831",
    "6dcal 3",
    "6d 2 [0 1.000][120.000 -350.500 1712.300 -8.6822 -4.9809 29.6217][0.866025 0.500000 "
    "0.000000 -0.492404 0.852869 -0.173648 -0.086824 0.150384 0.984808] [3 0.871][-812.400 "
    "1033.000 95.200 -0.0000 0.0000 -75.0000][0.258819 -0.965926 0.000000 0.965926 0.258819 "
    "0.000000 0.000000 0.000000 1.000000]",
    "6df2 1 1 [0 1.000 6 2][300.000 400.000 1100.000][1.000000 0.000000 0.000000 0.000000 "
    "0.939693 0.342020 0.000000 -0.342020 0.939693][5 0.25 -1.00]",
)

# The head is out of the cameras' view: DTrack2 leaves it out of the 6d line.
HEAD_LOST = datagram(
    "fr 21754",
    "ts 39596.041498",
    "6dcal 3",
    "6d 1 [3 0.869][-812.410 1033.020 95.190 -0.0000 0.0000 -75.0000][0.258819 -0.965926 "
    "0.000000 0.965926 0.258819 0.000000 0.000000 0.000000 1.000000]",
    "6df2 1 1 [0 1.000 6 2][310.000 400.000 1100.000][1.000000 0.000000 0.000000 0.000000 "
    "0.939693 0.342020 0.000000 -0.342020 0.939693][1 0.00 0.50]",
)

# The Flystick is hidden (quality -1, zeros for its pose); its radio still sends the
# buttons (button 4) and the joystick.
FLYSTICK_HIDDEN = datagram(
    "fr 21755",
    "ts 39596.058165",
    "6dcal 3",
    "6d 1 [0 1.000][121.500 -349.000 1710.000 -7.6500 -4.7551 31.6819][0.848048 0.529919 "
    "0.000000 -0.523395 0.837607 -0.156434 -0.082898 0.132664 0.987688]",
    "6df2 1 1 [0 -1.000 6 2][0.000 0.000 0.000][0.000000 0.000000 0.000000 0.000000 "
    "0.000000 0.000000 0.000000 0.000000 0.000000][16 -0.50 0.00]",
)

# Older DTrack2 versions: 3 decimals in the matrix, one in the angles (the manual's body).
THREE_DECIMALS = datagram(
    "fr 980",
    "ts 43210.500000",
    "6d 1 [0 1.000][326.848 -187.216 109.482 -160.1 -1.7 -4.3][0.997 0.081 -0.002 0.075 "
    "-0.937 -0.342 -0.030 0.340 -0.940]",
)

# Two Flysticks defined, two reported; Flystick 1 has 40 buttons (two button words: buttons
# 0, 31 and 33 down) and one controller.
TWO_FLYSTICKS = datagram(
    "fr 77",
    "6df2 2 2 [0 1.000 6 2][300.000 400.000 1100.000][1.000000 0.000000 0.000000 0.000000 "
    "0.939693 0.342020 0.000000 -0.342020 0.939693][0 0.00 0.00] [1 0.950 40 1][-20.000 "
    "15.500 990.000][0.965926 -0.258819 0.000000 0.212012 0.791240 0.573576 -0.148453 "
    "-0.554032 0.819152][2147483649 2 1.00]",
)

# Nothing in view: DTrack2 still sends the frame, with empty 6d and 6df2 lines.
NOTHING = datagram("fr 21760", "ts 39596.141498", "6dcal 3", "6d 0", "6df2 1 0")
