; store: every box on a storage cell (a derived atom); on completion box1, named here as the
; problem's object, is sent back to a2 (its storage cell becomes free). clear: a cell free of
; boxes and robot.
(define (domain warehouse-tasks)
  (:requirements :typing :negative-preconditions)
  (:action store
    :parameters (?c - cell)
    :precondition (and (stored) (at box1 ?c))
    :effect (and (not (at box1 ?c)) (at box1 a2)))
  (:action clear :parameters (?c - cell) :precondition (and (free ?c) (not (robot-at ?c))) :effect (and)))
