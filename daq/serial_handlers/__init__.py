"""pyserial URL handlers of cartlab: `protocol_sim` (`sim://`) and `protocol_replay` (`replay://`).

pyserial imports `<package>.protocol_<scheme>` and swallows ImportErrors there, so each
handler module is also import-tested directly.
"""
