"""The tracker-bridge process (`cavesim tracker`): DTrack2 datagrams in, head and wand out."""
