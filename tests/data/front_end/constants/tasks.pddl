; The task schemas name the problem's object b1 and the domain's constant dock.
(define (domain depot-tasks)
  (:requirements :typing)
  (:action post-b1
    :parameters (?p - place)
    :precondition (and (at b1 ?p) (robot-at dock))
    :effect (and))
  (:action fetch
    :parameters (?x - parcel)
    :precondition (and (at ?x office2) (not (robot-at dock)))
    :effect (and)))
