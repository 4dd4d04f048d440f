; The planetary rover of seed 001 (section 3.3): traverse, image, sample, and send data to the
; lander within its communication windows (timed initial literals). Traverse durations come
; from an external function, the path-planning reactor's estimate (module `path_estimate`).
;
; Inactive states (section 5.1): a predicate whose name starts with `inactive-` names a
; component's inactive state. An action that deletes such a fact at start and adds it back at
; end (imaging, sampling, sending) is pausable: when the planner is invoked while it runs, it
; stops and the component goes back to its inactive state; it is not done and the new plan
; does it again if it still needs to. A traverse has no inactive state in this model (a rover
; is idle only at a waypoint), so a traverse under way is not paused: it goes on to its
; waypoint and the replan keeps its end.
(define (domain rover-mission)
  (:requirements :typing :durative-actions :timed-initial-literals :numeric-fluents)
  (:types rover waypoint objective window)
  (:predicates
    (at ?r - rover ?w - waypoint)
    (path ?a ?b - waypoint)
    (visible-from ?o - objective ?w - waypoint)
    (rock-at ?w - waypoint)
    (lander-in-view ?w - waypoint)
    (have-image ?r - rover ?o - objective)
    (have-rock ?r - rover ?w - waypoint)
    (image-sent ?o - objective)
    (rock-sent ?w - waypoint)
    (comm-open ?c - window)
    (inactive-camera ?r - rover)
    (inactive-arm ?r - rover)
    (inactive-radio ?r - rover))
  (:functions (energy ?r - rover))
  (:modules (:module path_estimate (:function (traverse-time ?from ?to - waypoint))))
  (:durative-action traverse
    :parameters (?r - rover ?from ?to - waypoint)
    :duration (= ?duration (traverse-time ?from ?to))
    :condition (and (at start (at ?r ?from)) (over all (path ?from ?to)))
    :effect (and (at start (not (at ?r ?from))) (at end (at ?r ?to))))
  (:durative-action take-image
    :parameters (?r - rover ?o - objective ?w - waypoint)
    :duration (= ?duration 20)
    :condition (and (over all (at ?r ?w)) (at start (visible-from ?o ?w))
                    (at start (inactive-camera ?r)) (at start (>= (energy ?r) 2)))
    :effect (and (at start (not (inactive-camera ?r))) (at end (inactive-camera ?r))
                 (at end (have-image ?r ?o)) (at end (decrease (energy ?r) 2))))
  (:durative-action sample-rock
    :parameters (?r - rover ?w - waypoint)
    :duration (= ?duration 60)
    :condition (and (over all (at ?r ?w)) (at start (rock-at ?w))
                    (at start (inactive-arm ?r)) (at start (>= (energy ?r) 10)))
    :effect (and (at start (not (inactive-arm ?r))) (at end (inactive-arm ?r))
                 (at end (have-rock ?r ?w)) (at end (not (rock-at ?w)))
                 (at end (decrease (energy ?r) 10))))
  (:durative-action send-image
    :parameters (?r - rover ?o - objective ?w - waypoint ?c - window)
    :duration (= ?duration 15)
    :condition (and (over all (at ?r ?w)) (at start (lander-in-view ?w))
                    (at start (have-image ?r ?o)) (at start (inactive-radio ?r))
                    (over all (comm-open ?c)))
    :effect (and (at start (not (inactive-radio ?r))) (at end (inactive-radio ?r))
                 (at end (image-sent ?o))))
  (:durative-action send-rock-data
    :parameters (?r - rover ?s ?w - waypoint ?c - window)
    :duration (= ?duration 15)
    :condition (and (over all (at ?r ?w)) (at start (lander-in-view ?w))
                    (at start (have-rock ?r ?s)) (at start (inactive-radio ?r))
                    (over all (comm-open ?c)))
    :effect (and (at start (not (inactive-radio ?r))) (at end (inactive-radio ?r))
                 (at end (rock-sent ?s)))))
