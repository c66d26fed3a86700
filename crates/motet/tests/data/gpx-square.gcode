; A small print for gpx (Debian's G-code to X3G converter), machine r2h:
; heaters, homing, a square with extrusion, a dwell and the fan.
M104 S200 T0
M140 S50
G21
G90
G28 X Y Z
G92 X0 Y0 Z0 E0
M109 S200 T0
G1 Z0.3 F600
G1 X10 Y10 F3000
G1 X30 Y10 E1.5 F1200
G1 X30 Y30 E3.0
G1 X10 Y30 E4.5
G1 X10 Y10 E6.0
G4 P200
M106 S255
M107
M104 S0
M140 S0
