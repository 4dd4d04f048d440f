; A day of the rover: an image of o1, the rock at w2 sampled, an image of o2, all sent to the
; lander during one of its two communication windows. Waypoint positions (for the path
; estimate) are in the scenario file. The objectives o3 and o4 are the opportunistic targets
; the image analysis may report during the run (they are not goals here).
(define (problem rover-day) (:domain rover-mission)
  (:objects r0 - rover
            w0 w1 w2 w3 w4 w5 - waypoint
            o1 o2 o3 o4 - objective
            c1 c2 - window)
  (:init (at r0 w0)
         (path w0 w1) (path w1 w0) (path w1 w2) (path w2 w1) (path w2 w3) (path w3 w2)
         (path w0 w3) (path w3 w0) (path w3 w4) (path w4 w3) (path w4 w5) (path w5 w4)
         (visible-from o1 w1) (visible-from o2 w3) (visible-from o3 w2) (visible-from o4 w5)
         (rock-at w2)
         (lander-in-view w0) (lander-in-view w3)
         (inactive-camera r0) (inactive-arm r0) (inactive-radio r0)
         (= (energy r0) 100)
         (at 600 (comm-open c1)) (at 900 (not (comm-open c1)))
         (at 1200 (comm-open c2)) (at 2400 (not (comm-open c2))))
  (:goal (and (image-sent o1) (rock-sent w2) (image-sent o2))))
