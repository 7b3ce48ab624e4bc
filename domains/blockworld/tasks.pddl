; The blockworld's task types: one action schema per type, its precondition the
; goal. A task names a job of the layout's library (the `wants` facts of its problem
; file say which blocks it wants in which regions); the blocks and regions are
; existential parameters that only the job's own facts bind. The hand must be free,
; as in the sources (a task holds only once the last block is put down). Nothing is
; consumed: the blocks stay where the task left them, for the tasks that follow.
(define (domain blockworld-tasks)
  (:requirements :typing :equality :negative-preconditions :existential-preconditions)

  ; One block in one coloured region.
  (:action one-block
    :parameters (?j - single-job ?b - colored-block ?r - colored-region)
    :precondition (and (wants ?j ?b ?r) (at ?b ?r) (hand-free))
    :effect (and))

  ; Two blocks, each in its own coloured region.
  (:action two-blocks
    :parameters (?j - pair-job ?b1 ?b2 - colored-block ?r1 ?r2 - colored-region)
    :precondition (and (wants ?j ?b1 ?r1) (wants ?j ?b2 ?r2) (not (= ?b1 ?b2))
                       (at ?b1 ?r1) (at ?b2 ?r2) (hand-free))
    :effect (and)))
