; A long day of the rover (issue 13 item 3, long plans divided across windows): thirty
; objectives to image and send to the lander, about 70 actions in one plan. The same domain
; as the other rover scenarios; the communication window is long enough for every send.
(define (problem rover-long-day) (:domain rover-mission)
  (:objects r0 - rover
            w0 w1 w2 w3 w4 w5 - waypoint
            o1 o2 o3 o4 o5 o6 o7 o8 o9 o10 o11 o12 o13 o14 o15 o16 o17 o18 o19 o20 o21 o22 o23 o24 o25 o26 o27 o28 o29 o30 - objective
            c1 - window)
  (:init (at r0 w0)
         (path w0 w1) (path w1 w0) (path w1 w2) (path w2 w1) (path w2 w3) (path w3 w2)
         (path w0 w3) (path w3 w0) (path w3 w4) (path w4 w3) (path w4 w5) (path w5 w4)
         (visible-from o1 w1) (visible-from o2 w2) (visible-from o3 w3) (visible-from o4 w4) (visible-from o5 w5) (visible-from o6 w1) (visible-from o7 w2) (visible-from o8 w3) (visible-from o9 w4) (visible-from o10 w5) (visible-from o11 w1) (visible-from o12 w2) (visible-from o13 w3) (visible-from o14 w4) (visible-from o15 w5) (visible-from o16 w1) (visible-from o17 w2) (visible-from o18 w3) (visible-from o19 w4) (visible-from o20 w5) (visible-from o21 w1) (visible-from o22 w2) (visible-from o23 w3) (visible-from o24 w4) (visible-from o25 w5) (visible-from o26 w1) (visible-from o27 w2) (visible-from o28 w3) (visible-from o29 w4) (visible-from o30 w5)
         (lander-in-view w0) (lander-in-view w3)
         (inactive-camera r0) (inactive-arm r0) (inactive-radio r0)
         (= (energy r0) 100)
         (at 600 (comm-open c1)) (at 5400 (not (comm-open c1))))
  (:goal (and (image-sent o1) (image-sent o2) (image-sent o3) (image-sent o4) (image-sent o5) (image-sent o6) (image-sent o7) (image-sent o8) (image-sent o9) (image-sent o10) (image-sent o11) (image-sent o12) (image-sent o13) (image-sent o14) (image-sent o15) (image-sent o16) (image-sent o17) (image-sent o18) (image-sent o19) (image-sent o20) (image-sent o21) (image-sent o22) (image-sent o23) (image-sent o24) (image-sent o25) (image-sent o26) (image-sent o27) (image-sent o28) (image-sent o29) (image-sent o30))))
