; The reconfigurable mill's job (examples/modules): a slot along each of
; the four faces of a square bar held in the A axis, the bar turned a
; quarter turn between faces, then a helical cut turning A as X moves.
; Uses X Y Z A and the spindle (M3/M5).
G21 G90 G94
M3 S12000            ; spindle on (it settles before anything moves)
G0 X20 Y150 Z110 A0
G1 Z100 F300         ; plunge, 5 mm/s
G1 X200 F1800        ; along the face, 30 mm/s
G0 Z110
G0 X20 A90           ; next face
G1 Z100 F300
G1 X200 F1800
G0 Z110
G0 X20 A180
G1 Z100 F300
G1 X200 F1800
G0 Z110
G0 X20 A-90
G1 Z100 F300
G1 X200 F1800
G0 Z110
G0 X20 A0
G1 Z101 F300
G1 X120 A90 F1200    ; helix: A turns as X moves
G1 X20 A0
G0 Z120
M5                   ; spindle off
G0 X0 Y0 A0
M2
