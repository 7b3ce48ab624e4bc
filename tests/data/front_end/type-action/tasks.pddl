; charge: a task named like the action and the type; recharged: the robot charged at a spot.
(define (domain charging-tasks)
  (:requirements :typing)
  (:action charge :parameters () :precondition (charged) :effect (not (charged)))
  (:action recharged :parameters (?s - spot) :precondition (and (charged) (robot-at ?s)) :effect (and)))
